"""A gallery of generated worlds, each drawn from above (no rendering, no GL).

Each world is drawn with its manifolds, obstacles and teleop routes, captioned with its name,
manifold count and depth.

``python -m scripts.world_gallery --family hallway --out docs/img/gallery_hallway.png`` draws
the first 12 train worlds of a family; the docs and the report show these figures.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

from common.fileio import write_png
from scenes import build_world
from scenes.families import split_worlds
from sim.topdown import TopDownView

TILE = 300  # pixels per side of one world's drawing
CAPTION = 22  # pixels of caption under it


def world_tile(name: str, size: int = TILE) -> np.ndarray:
    """Draw one world from above: manifolds, obstacles and routes (red), with a caption.

    Parameters
    ----------
    name : str
        The world.
    size : int, default TILE
        Pixels per side of the drawing.

    Returns
    -------
    ndarray of uint8 of shape (size + CAPTION, size, 3)
        The tile.
    """
    world = build_world(name)
    view = TopDownView(world, max_size=size - 8)
    img = view.draw()
    for route in world.routes.values():
        px = np.round(view.to_pixels(route.waypoints)).astype(np.int32)
        cv2.polylines(img, [px], False, (200, 30, 30), 1, cv2.LINE_AA)
    tile = np.full((size + CAPTION, size, 3), 255, np.uint8)
    h, w = img.shape[:2]
    y0, x0 = (size - h) // 2, (size - w) // 2
    tile[y0 : y0 + h, x0 : x0 + w] = img
    depth = max(world.junctions_between(world.manifold_names[0], m) for m in world.routes)
    text = f"{name}: {len(world.manifold_names)} manifolds, depth {depth}"
    cv2.putText(
        tile, text, (6, size + 15), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (0, 0, 0), 1, cv2.LINE_AA
    )
    return tile


def gallery(names: list[str], columns: int = 4, size: int = TILE) -> np.ndarray:
    """Lay out the tiles of ``names`` in rows of ``columns``.

    Parameters
    ----------
    names : list of str
        The worlds.
    columns : int, default 4
        Tiles per row; blank tiles fill the last.
    size : int, default TILE
        Pixels per side of one tile's drawing.

    Returns
    -------
    ndarray of uint8
        The gallery image.
    """
    tiles = [world_tile(n, size) for n in names]
    blank = np.full_like(tiles[0], 255)
    tiles += [blank] * (-len(tiles) % columns)
    rows = [np.hstack(tiles[k : k + columns]) for k in range(0, len(tiles), columns)]
    return np.vstack(rows)


def main(argv=None) -> int:
    """Draw the gallery of a family's split and write it as PNG.

    Parameters
    ----------
    argv : list of str or None, default None
        The arguments; None reads ``sys.argv[1:]``.

    Returns
    -------
    int
        The exit status, 0.
    """
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--family", choices=("hallway", "lawn"), required=True)
    parser.add_argument("--split", choices=("train", "dev", "test"), default="train")
    parser.add_argument("--count", type=int, default=12)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    names = split_worlds(args.family, args.split, args.count)
    print(write_png(args.out, gallery(names)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
