"""A gallery of generated worlds: each drawn from above with its manifolds, obstacles and
teleop routes, captioned with its name, manifold count and depth (no rendering, no GL).

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
    """One world from above: manifolds, obstacles and routes (red), with a caption."""
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
    """The tiles of ``names`` in rows of ``columns``."""
    tiles = [world_tile(n, size) for n in names]
    blank = np.full_like(tiles[0], 255)
    tiles += [blank] * (-len(tiles) % columns)
    rows = [np.hstack(tiles[k : k + columns]) for k in range(0, len(tiles), columns)]
    return np.vstack(rows)


def main(argv=None) -> int:
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
