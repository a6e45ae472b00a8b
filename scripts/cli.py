"""The ``topomap`` command line.

``topomap --help`` lists every subcommand with the one-line ``help=`` it is registered with
(`command_listing`), so the list cannot go stale.
"""

from __future__ import annotations

import argparse
import sys
import time

from scripts.args import (
    WORLD_HELP,
    non_negative_int,
    output_folder,
    policies,
    positive_int,
    world_choice,
    worlds,
)

DEFAULT_OUT = "out"
HELDOUT_HELP = "clustering and grouping on held-out generated worlds beside the canonical"
LEADERBOARD_HELP = "rank result files per task and protocol, paired against a reference"
MANIFOLD_EVAL_HELP = "any scikit-learn clusterer through the manifold-clustering protocol"
SUMMARY = (
    "Simulated robot worlds and datasets, two topological mapping methods (Grudic &\n"
    "Mulligan's visual manifold clustering, Blanco et al.'s laser observation grouping)\n"
    "and closed-loop visual servoing between places."
)


def cmd_import(args) -> int:
    """Import a robot's ROS 1 / ROS 2 bags as a dataset (``sim.readers.rosbag``).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of ``topomap import``.

    Returns
    -------
    int
        The exit status: 0, or 2 when the dataset exists already.
    """
    from sim.dataset import load_dataset
    from sim.readers import ImportSettings, import_rosbags

    settings = ImportSettings(
        scan_topic=args.scan_topic,
        image_topic=args.image_topic,
        odom_topic=args.odom_topic,
        world=args.world,
        image_tolerance=args.image_tolerance,
        odom_max_gap=args.odom_max_gap,
        min_travel=args.min_travel,
        min_turn=args.min_turn,
        laser_offset=tuple(args.laser_offset),
    )
    try:
        out = import_rosbags(
            args.rosbag, args.out, settings, overwrite=args.overwrite, progress=not args.quiet
        )
    except FileExistsError as err:
        print(f"topomap import: {err}", file=sys.stderr)
        return 2
    for name, seq in load_dataset(out).sequences.items():
        print(f"{name}: {len(seq)} frames, {seq.times[-1]:.1f} s")
    print(f"dataset ready in {out} (no ground truth)")
    return 0


def cmd_preview(args) -> int:
    """Write contact sheets and trajectory maps of a dataset.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of ``topomap preview``.

    Returns
    -------
    int
        The exit status, 0.
    """
    from scripts.preview import write_previews
    from sim.dataset import load_dataset

    output_folder(args.out)
    written = write_previews(load_dataset(args.data), args.out)
    print(f"wrote {len(written)} preview images to {args.out}")
    return 0


def cmd_worlds(args) -> int:
    """Write the worlds' MJCF and textures (for MuJoCo's viewer).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of ``topomap worlds``.

    Returns
    -------
    int
        The exit status, 0.
    """
    from scenes import build_world

    output_folder(args.out)
    for name in worlds(args.world):
        print(build_world(name).write(args.out))
    return 0


def _protocol_folder(value: str | None) -> str | None:
    """Return the folder a ``--protocol`` value names, or None.

    "committed" (the default) is the repository's ``docs/results/data/manifold/protocol`` when
    present, "none" shows no spread, else a folder.
    """
    from scripts.report import COMMITTED_PROTOCOL

    if value == "committed":
        return str(COMMITTED_PROTOCOL) if (COMMITTED_PROTOCOL / "cells").is_dir() else None
    return None if value in (None, "none") else value


def cmd_run(args) -> int:
    """Run the main job, end to end on the default worlds.

    It collects the default dataset (reused when present), evaluates both mapping methods and
    the servo, and writes ``<out>/report/``.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of ``topomap run``.

    Returns
    -------
    int
        The exit status: 0, 2 for a bad output folder or dataset, 1 for a failed stage.
    """
    from scripts.report import OutputError, RunSettings, StageError, run_pipeline

    settings = RunSettings(
        seed=args.seed,
        episodes=args.episodes,
        policies=("servo", *(p for p in args.baselines if p != "servo")),
        videos=args.videos,
        grouping_loop=args.grouping_loop,
        jobs=args.jobs,
        protocol=_protocol_folder(args.protocol),
    )
    rest = [
        f"--seed {args.seed}",
        f"--episodes {args.episodes}",
        f"--baselines {','.join(settings.policies[1:])}",
        f"--videos {args.videos}",
    ]
    rest += ["--grouping-loop"] * args.grouping_loop
    rest += [f"--protocol {args.protocol}"] * (args.protocol not in (None, "committed"))
    start = time.perf_counter()
    try:
        index = run_pipeline(
            args.out, settings, progress=not args.quiet, command=" ".join(["topomap run", *rest])
        )
    except OutputError as err:
        print(f"topomap run: --{err}", file=sys.stderr)
        return 2
    except StageError as err:
        if isinstance(err.__cause__, FileExistsError):  # the dataset of another seed
            print(
                f"topomap run: {err.__cause__}\n(topomap run reuses <out>/dataset; for another "
                "seed or settings, remove it or give another --out)",
                file=sys.stderr,
            )
            return 2
        import traceback

        traceback.print_exception(err.__cause__ or err)
        print(f"topomap run: {err}", file=sys.stderr)
        return 1
    print(f"report: {index}\ndone in {time.perf_counter() - start:.1f} s")
    return 0


def cmd_group_eval(args) -> int:
    """Evaluate the laser observation grouping (Blanco et al.).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of ``topomap group-eval``.

    Returns
    -------
    int
        The exit status.
    """
    output_folder(args.out)
    from scripts.grouping import carmen_eval, group_eval, local_maps_eval

    if args.method:
        return group_eval(args)  # the outside estimator (scripts.grouping.outside)
    if args.data is not None:
        from scripts.data_needed import ensure_dataset
        from scripts.grouping import one_dataset

        one_dataset(args)
        args.data = ensure_dataset(args.data, "group-eval", progress=not args.quiet)
    if args.local_maps:
        return local_maps_eval(args)
    if args.carmen:
        return carmen_eval(args)
    return group_eval(args)


def cmd_reproduce(args) -> int:
    """Reproduce the manifold-clustering paper's experiments.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of ``topomap reproduce``.

    Returns
    -------
    int
        The exit status.
    """
    from scripts.manifold import reproduce_command

    output_folder(args.out)
    return reproduce_command(args)


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """Build the ``topomap`` parser.

    With ``command``, the subcommands whose options are declared by a heavy module
    (``reproduce``, ``group-eval``: scikit-learn, the experiments) get them only if they are
    ``command`` ("": neither); the others list them all, so ``topomap --help`` need not import
    every experiment (it took ~3 s).

    Parameters
    ----------
    command : str or None, default None
        The subcommand about to run; None declares every subcommand's options.

    Returns
    -------
    argparse.ArgumentParser
        The parser.
    """
    from scripts.collect_command import add_parser as add_collect_parser
    from scripts.servo_commands import add_parsers as add_servo_parsers

    # the commands are listed in the description (command_listing), one line each, instead of
    # argparse's own list, which wraps help lines and repeats every name in the usage
    p = argparse.ArgumentParser(
        prog="topomap",
        usage="%(prog)s [-h] COMMAND ...",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="topomap COMMAND --help shows the options of one command.",
    )
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND", help=argparse.SUPPRESS)

    add_collect_parser(sub)

    i = sub.add_parser("import", help="a robot's ROS 1 / ROS 2 bags as a dataset (own data)")
    i.add_argument("--rosbag", nargs="+", required=True, help="bags: drives through one place")
    i.add_argument(
        "--scan-topic",
        default=None,
        help="sensor_msgs/LaserScan topic; leave out for a robot without a laser "
        "(camera and odometry only)",
    )
    i.add_argument(
        "--image-topic",
        default=None,
        help="sensor_msgs/Image or CompressedImage; leave out for a robot without a "
        "camera (laser and odometry only)",
    )
    i.add_argument("--odom-topic", required=True, help="nav_msgs/Odometry topic")
    i.add_argument("--out", required=True, help="dataset directory (must not exist yet)")
    i.add_argument("--world", default="robot", help="name of the place (default: robot)")
    i.add_argument("--image-tolerance", type=float, default=0.1, help="s, scan to image")
    i.add_argument("--odom-max-gap", type=float, default=0.5, help="s, between odometry msgs")
    i.add_argument("--min-travel", type=float, default=0.1, help="m between frames (0: off)")
    i.add_argument("--min-turn", type=float, default=0.2, help="rad between frames (0: off)")
    i.add_argument(
        "--laser-offset",
        type=float,
        nargs=3,
        default=(0.0, 0.0, 0.0),
        metavar=("X", "Y", "YAW"),
        help="the laser's pose on the robot (m, m, rad)",
    )
    i.add_argument("--overwrite", action="store_true", help="replace an imported dataset")
    i.add_argument("--quiet", action="store_true", help="no progress bar")
    i.set_defaults(func=cmd_import)

    v = sub.add_parser("preview", help="contact sheets and trajectory maps of a dataset")
    v.add_argument("--data", required=True)
    v.add_argument("--out", required=True)
    v.set_defaults(func=cmd_preview)

    w = sub.add_parser("worlds", help="write the worlds' MJCF and textures (for MuJoCo's viewer)")
    w.add_argument("--world", type=world_choice, default="all", metavar="WORLD", help=WORLD_HELP)
    w.add_argument("--out", required=True)
    w.set_defaults(func=cmd_worlds)

    r = sub.add_parser("run", help="the main job end to end on the default worlds")
    r.add_argument(
        "--out", default=DEFAULT_OUT, help="folder for the dataset, maps and report/ (default: out)"
    )
    r.add_argument(
        "--seed",
        type=non_negative_int,
        default=0,
        help="seeds the dataset and the servo episodes (integer >= 0; default 0)",
    )
    r.add_argument("--jobs", type=positive_int, default=None, help="collection processes")
    r.add_argument(
        "--episodes",
        type=positive_int,
        default=20,
        help="servo episodes per world, start tier and policy (the benchmark's test split)",
    )
    r.add_argument(
        "--baselines",
        type=policies,
        default=("signal",),
        help="comma-separated policies beside the servo policy: signal (servo by F, camera "
        "only), oracle, random, greedy (greedy probing is slow: about 10x a servo episode)",
    )
    r.add_argument("--videos", type=int, default=1, help="servo episode videos per world")
    r.add_argument("--grouping-loop", action="store_true", help="also group a loop per world")
    r.add_argument(
        "--protocol",
        default="committed",
        metavar="DIR",
        help="a folder written by python -m scripts.manifold.protocol --out DIR: the report "
        "shows its per-seed manifold-clustering errors (the run does not compute them); "
        "default: the cells committed in docs/results/data/manifold/protocol; 'none': no table",
    )
    r.add_argument("--quiet", action="store_true", help="no progress bars")
    r.set_defaults(func=cmd_run)

    m = sub.add_parser("reproduce", help="reproduce the manifold-clustering paper's experiments")
    if command in (None, "reproduce"):
        from scripts.manifold import reproduce_parser

        reproduce_parser(m).set_defaults(func=cmd_reproduce)

    g = sub.add_parser("group-eval", help="evaluate the laser observation grouping (Blanco et al.)")
    if command in (None, "group-eval"):
        from scripts.grouping import group_eval_parser

        group_eval_parser(g).set_defaults(func=cmd_group_eval)

    if command in (None, "manifold-eval"):
        from scripts.manifold import manifold_eval_parser

        manifold_eval_parser(sub, MANIFOLD_EVAL_HELP)
    else:
        sub.add_parser("manifold-eval", help=MANIFOLD_EVAL_HELP)

    add_servo_parsers(sub, default_out=DEFAULT_OUT)

    from scripts.sweep import add_parser as add_sweep_parser

    add_sweep_parser(sub, default_out=DEFAULT_OUT)
    h = sub.add_parser("heldout", help=HELDOUT_HELP)
    if command in (None, "heldout"):
        from scripts.heldout import heldout_parser, run_heldout

        heldout_parser(h).set_defaults(func=run_heldout)
    if command in (None, "leaderboard"):  # scipy loads only for this command
        from scripts.leaderboard import leaderboard_parser

        leaderboard_parser(sub, LEADERBOARD_HELP)
    else:
        sub.add_parser("leaderboard", help=LEADERBOARD_HELP)
    p.description = f"{SUMMARY}\n\ncommands:\n{command_listing(sub)}"
    return p


def command_listing(sub: argparse.Action) -> str:
    """List the subcommands registered on the subparsers action ``sub``, one line each.

    In the order registered: its name, then the ``help=`` it was added with (blank without
    one).

    Parameters
    ----------
    sub : argparse.Action
        The subparsers action.

    Returns
    -------
    str
        The lines, joined by newlines.
    """
    # argparse keeps each help= in _choices_actions (what its own listing reads; no public
    # accessor) and leaves out a subcommand added without one: the names come from choices
    helps = {a.dest: a.help for a in sub._choices_actions}
    names = list(sub.choices)
    width = max(map(len, names))
    return "\n".join(f"  {name:<{width}}  {helps.get(name) or ''}".rstrip() for name in names)


def _os_message(err: OSError) -> str:
    """Return one line for an OSError: what failed on which path.

    ``str(err)`` already names the path for the errors ``open`` and ``mkdir`` raise.
    """
    text = str(err) or type(err).__name__
    return text if err.filename is not None else f"{type(err).__name__}: {text}"


def main(argv: list[str] | None = None) -> int:
    """Run the ``topomap`` command line.

    Parameters
    ----------
    argv : list of str or None, default None
        The arguments; None reads ``sys.argv[1:]``.

    Returns
    -------
    int
        The exit status: the subcommand's, 2 for bad settings, 1 for a file that cannot be
        read or written.
    """
    import sim  # noqa: F401  (chooses the headless GL backend before mujoco loads)

    argv = sys.argv[1:] if argv is None else list(argv)
    # the subcommand is the first word (``topomap`` itself has no options but --help)
    command = next((a for a in argv if not a.startswith("-")), "")
    args = build_parser(command).parse_args(argv)
    try:
        return args.func(args)
    except ValueError as err:  # bad settings: say which, no traceback
        print(f"topomap {args.command}: {err}", file=sys.stderr)
        return 2
    except OSError as err:  # a file or folder that cannot be read or written: say which
        print(f"topomap {args.command}: {_os_message(err)}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    raise SystemExit(main())
