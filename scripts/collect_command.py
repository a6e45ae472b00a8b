"""``topomap collect``: record a teleop dataset (resumable) with the settings given."""

from __future__ import annotations

import sys
import time

from scripts.args import (
    WORLD_HELP,
    frame_count,
    non_negative_float,
    non_negative_int,
    output_folder,
    positive_int,
    world_choice,
    worlds,
)


def _settings(args):
    from sim.camera import CameraConfig
    from sim.collect import CollectionSettings
    from sim.laser import LaserConfig
    from sim.teleop import TeleopConfig

    return CollectionSettings(
        worlds=worlds(args.world),
        frames=args.frames,
        seed=args.seed,
        randomize=args.randomize,
        appearance=args.appearance,
        camera=CameraConfig(width=args.width, height=args.height, depth=args.depth),
        laser=LaserConfig(beams=args.beams, max_range=args.max_range),
        teleop=TeleopConfig().scaled(args.teleop_jitter),
    )


def cmd_collect(args) -> int:
    """Collect a teleop dataset with the settings given.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of ``topomap collect``.

    Returns
    -------
    int
        The exit status: 0, or 2 when a dataset with other settings exists already.
    """
    from sim.collect import collect_dataset

    settings = _settings(args)  # bad settings are refused before the folder is made
    output_folder(args.out)
    start = time.perf_counter()
    try:
        out = collect_dataset(args.out, settings, overwrite=args.overwrite, jobs=args.jobs)
    except FileExistsError as err:
        print(f"topomap collect: {err}", file=sys.stderr)
        return 2
    print(f"dataset ready in {out} ({time.perf_counter() - start:.1f} s)")
    return 0


def add_parser(sub) -> None:
    """Add the ``collect`` subcommand to the ``topomap`` parser's subparsers ``sub``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subparsers of the ``topomap`` parser.
    """
    from scenes.appearance import APPEARANCE_MODES

    c = sub.add_parser("collect", help="collect a teleop dataset (resumable)")
    c.add_argument("--world", type=world_choice, required=True, metavar="WORLD", help=WORLD_HELP)
    c.add_argument("--out", required=True, help="dataset directory")
    c.add_argument(
        "--seed",
        type=non_negative_int,
        default=0,
        help="seeds the driver, the sensor noise and randomised worlds (integer >= 0; default 0)",
    )
    c.add_argument(
        "--frames", type=frame_count, default=150, help="frames per sequence (>= 2; default 150)"
    )
    c.add_argument("--randomize", action="store_true", help="domain-randomised worlds")
    c.add_argument(
        "--appearance",
        choices=APPEARANCE_MODES,
        default="default",
        help="hard: every branch shares the main manifold's wall, floor and light materials, "
        "so only the layout tells the manifolds apart (default: each its own)",
    )
    c.add_argument(
        "--teleop-jitter",
        type=non_negative_float,
        default=1.0,
        metavar="SCALE",
        help="scale of the driver's random speed, turn, wander and start jitter (0: the route's "
        "centre line, the same pass for every seed; default 1)",
    )
    c.add_argument("--overwrite", action="store_true", help="replace a dataset with other settings")
    c.add_argument(
        "--jobs", type=positive_int, default=None, help="worker processes (default: cores)"
    )
    c.add_argument(
        "--width", type=positive_int, default=320, help="image width in pixels (default 320)"
    )
    c.add_argument(
        "--height", type=positive_int, default=240, help="image height in pixels (default 240)"
    )
    c.add_argument("--depth", action="store_true", help="also record depth images")
    c.add_argument(
        "--beams",
        type=positive_int,
        default=361,
        help="laser beams over its 180 deg field of view (default 361: 0.5 deg apart)",
    )
    c.add_argument(
        "--max-range",
        type=float,
        default=20.0,
        help="laser range in metres; a beam with no return reads inf (default 20)",
    )
    c.set_defaults(func=cmd_collect)
