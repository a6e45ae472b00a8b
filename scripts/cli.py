"""The ``topomap`` command line: ``collect``, ``preview``, ``worlds`` and ``run``."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

DEFAULT_OUT = "out"


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {text}")
    return value


def _worlds(choice: str) -> tuple[str, ...]:
    from scenes import WORLDS

    return WORLDS if choice == "all" else (choice,)


def _settings(args):
    from sim.camera import CameraConfig
    from sim.collect import CollectionSettings
    from sim.laser import LaserConfig

    return CollectionSettings(
        worlds=_worlds(args.world),
        frames=args.frames,
        seed=args.seed,
        randomize=args.randomize,
        camera=CameraConfig(width=args.width, height=args.height, depth=args.depth),
        laser=LaserConfig(beams=args.beams, max_range=args.max_range),
    )


def cmd_collect(args) -> int:
    from sim.collect import collect_dataset

    start = time.perf_counter()
    try:
        out = collect_dataset(args.out, _settings(args), overwrite=args.overwrite, jobs=args.jobs)
    except FileExistsError as err:
        print(f"topomap collect: {err}", file=sys.stderr)
        return 2
    print(f"dataset ready in {out} ({time.perf_counter() - start:.1f} s)")
    return 0


def cmd_preview(args) -> int:
    from scripts.preview import write_previews
    from sim.dataset import load_dataset

    written = write_previews(load_dataset(args.data), args.out)
    print(f"wrote {len(written)} preview images to {args.out}")
    return 0


def cmd_worlds(args) -> int:
    from scenes import build_world

    for name in _worlds(args.world):
        print(build_world(name).write(args.out))
    return 0


def cmd_run(args) -> int:
    """The main job, end to end on the default worlds: collect the default dataset (reused when
    present) and write previews."""
    from scripts.preview import write_previews
    from sim.collect import CollectionSettings, collect_dataset
    from sim.dataset import load_dataset

    out = Path(args.out)
    data_dir = out / "dataset"
    start = time.perf_counter()
    try:
        collect_dataset(data_dir, CollectionSettings(seed=args.seed), jobs=args.jobs)
    except FileExistsError as err:
        print(f"topomap run: {err}", file=sys.stderr)
        return 2
    written = write_previews(load_dataset(data_dir), out / "preview")
    print(
        f"dataset: {data_dir}\npreviews: {len(written)} images in {out / 'preview'}\n"
        f"done in {time.perf_counter() - start:.1f} s"
    )
    return 0


def cmd_group_eval(args) -> int:
    from scripts.eval_grouping import run

    return run(args)


def build_parser() -> argparse.ArgumentParser:
    from scenes import WORLDS

    p = argparse.ArgumentParser(prog="topomap", description=__doc__)
    sub = p.add_subparsers(dest="command", required=True)

    c = sub.add_parser("collect", help="collect a teleop dataset (resumable)")
    c.add_argument("--world", choices=(*WORLDS, "all"), required=True)
    c.add_argument("--out", required=True, help="dataset directory")
    c.add_argument("--seed", type=int, default=0)
    c.add_argument("--frames", type=_positive_int, default=150, help="frames per sequence")
    c.add_argument("--randomize", action="store_true", help="domain-randomised worlds")
    c.add_argument("--overwrite", action="store_true", help="replace a dataset with other settings")
    c.add_argument(
        "--jobs", type=_positive_int, default=None, help="worker processes (default: cores)"
    )
    c.add_argument("--width", type=_positive_int, default=320)
    c.add_argument("--height", type=_positive_int, default=240)
    c.add_argument("--depth", action="store_true", help="also record depth images")
    c.add_argument("--beams", type=_positive_int, default=361)
    c.add_argument("--max-range", type=float, default=20.0)
    c.set_defaults(func=cmd_collect)

    v = sub.add_parser("preview", help="contact sheets and trajectory maps of a dataset")
    v.add_argument("--data", required=True)
    v.add_argument("--out", required=True)
    v.set_defaults(func=cmd_preview)

    w = sub.add_parser("worlds", help="write the worlds' MJCF and textures (for MuJoCo's viewer)")
    w.add_argument("--world", choices=(*WORLDS, "all"), default="all")
    w.add_argument("--out", required=True)
    w.set_defaults(func=cmd_worlds)

    r = sub.add_parser("run", help="the main job end to end on the default worlds")
    r.add_argument("--out", default=DEFAULT_OUT)
    r.add_argument("--seed", type=int, default=0)
    r.add_argument("--jobs", type=_positive_int, default=None)
    r.set_defaults(func=cmd_run)

    from scripts.eval_grouping import build_parser as group_eval_parser

    g = sub.add_parser("group-eval", help="evaluate the laser observation grouping (Blanco et al.)")
    group_eval_parser(g).set_defaults(func=cmd_group_eval)
    return p


def main(argv: list[str] | None = None) -> int:
    import sim  # noqa: F401  (chooses the headless GL backend before mujoco loads)

    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except ValueError as err:  # bad settings: say which, no traceback
        print(f"topomap {args.command}: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
