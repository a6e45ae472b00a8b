"""The ``topomap`` command line. ``topomap --help`` lists every subcommand with the one-line
``help=`` it is registered with (:func:`command_listing`), so the list cannot go stale."""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time

from scripts.args import (
    non_negative_int,
    output_folder,
    policies,
    policy_arg,
    policy_name,
    positive_int,
    worlds,
)

DEFAULT_OUT = "out"
LEADERBOARD_HELP = "rank result files per task and protocol, paired against a reference"
MANIFOLD_EVAL_HELP = "any scikit-learn clusterer through the manifold-clustering protocol"
SUMMARY = (
    "Simulated robot worlds and datasets, two topological mapping methods (Grudic &\n"
    "Mulligan's visual manifold clustering, Blanco et al.'s laser observation grouping)\n"
    "and closed-loop visual servoing between places."
)


def cmd_import(args) -> int:
    """A robot's ROS 1 / ROS 2 bags as a dataset (``sim.readers.rosbag``)."""
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
    from scripts.preview import write_previews
    from sim.dataset import load_dataset

    output_folder(args.out)
    written = write_previews(load_dataset(args.data), args.out)
    print(f"wrote {len(written)} preview images to {args.out}")
    return 0


def cmd_worlds(args) -> int:
    from scenes import build_world

    output_folder(args.out)
    for name in worlds(args.world):
        print(build_world(name).write(args.out))
    return 0


def _protocol_folder(value: str | None) -> str | None:
    """``--protocol``: "committed" (the default) is the repository's
    ``docs/results/data/manifold/protocol`` when present, "none" shows no spread, else a folder."""
    from scripts.report import COMMITTED_PROTOCOL

    if value == "committed":
        return str(COMMITTED_PROTOCOL) if (COMMITTED_PROTOCOL / "cells").is_dir() else None
    return None if value in (None, "none") else value


def cmd_run(args) -> int:
    """The main job, end to end on the default worlds: collect the default dataset (reused when
    present), evaluate both mapping methods and the servo, and write ``<out>/report/``."""
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
    output_folder(args.out)
    from scripts.grouping import carmen_eval, group_eval, local_maps_eval

    if args.method:
        return group_eval(args)  # the outside estimator (scripts.grouping.outside)
    if args.data is not None:
        from scripts.grouping import one_dataset

        one_dataset(args)
    if args.local_maps:
        return local_maps_eval(args)
    if args.carmen:
        return carmen_eval(args)
    return group_eval(args)


def cmd_reproduce(args) -> int:
    from scripts.manifold import reproduce_command

    output_folder(args.out)
    return reproduce_command(args)


def servo_eval_name(args) -> str:
    """The results file of ``servo-eval --out``: every setting that changes the episodes is in
    the name, so runs of other worlds or settings into one folder do not overwrite each other."""
    extras = "-randomize" * bool(args.randomize) + "-no-odometry-noise" * bool(
        args.no_odometry_noise
    )
    steps = "" if args.max_steps == 600 else f"-{args.max_steps}steps"
    # an outside policy: its spec with ':' as '.', and its params' digest (runs differ by them)
    params = dict(args.policy_arg or [])
    digest = hashlib.sha256(json.dumps(params, sort_keys=True).encode()).hexdigest()[:8]
    tag = args.policy.replace(":", ".") + (f"-{digest}" if params else "")
    return (
        f"servo-eval-{args.world}-{args.tier}-{args.split}-{tag}"
        f"-{args.episodes}ep{extras}{steps}.json"
    )


def cmd_servo_eval(args) -> int:
    """Closed-loop servo evaluation by the benchmark protocol (``servo.task.protocol``): one start
    tier and split, in one world or both, episodes in parallel over the cores; ``--policy``
    one of ours or an outside factory ``package.module:factory`` with ``--policy-arg``s."""
    from servo.maps import load_or_build, map_paths
    from servo.task import Protocol, run_protocol

    out = output_folder(args.out) if args.out else None
    results = []
    for world in worlds(args.world):
        protocol = Protocol(world, args.tier, args.split, randomize=args.randomize,
                            odometry_noise=not args.no_odometry_noise,
                            max_steps=args.max_steps)  # fmt: skip
        servo_map = load_or_build(world, dataset=args.data, cache=args.maps)
        path, _ = map_paths(args.maps, world, servo_map.key)
        r = run_protocol(protocol, path if path.is_file() else servo_map, args.episodes,
                         args.policy, workers=args.workers, progress=not args.json,
                         policy_options=dict(args.policy_arg or []))  # fmt: skip
        not_loaded = r["reasons"].get("policy not loaded", 0)
        if not_loaded:  # every episode failed so: say why here too, not only in the records
            why = next(e["failure"] for e in r["episodes_detail"] if "failure" in e)
            print(f"topomap servo-eval: {why}", file=sys.stderr)
        results.append(r)
    if out is not None:
        from scripts.leaderboard import servo_result_file, write_result

        # the results inside the envelope every evaluation writes (scripts.leaderboard)
        write_result(
            out / servo_eval_name(args), servo_result_file(results, args.policy, args.split)
        )
    if args.json:
        print(json.dumps(results if len(results) > 1 else results[0], indent=2))
        return 0
    from scripts.servo_tables import pair_table, summary_table

    print(summary_table(results).to_markdown())
    for r in results:
        sig = r["signal"]
        if sig["pairs"]:
            print(f"{r['world']} {r['policy']}: F toward the target rises as the true "
                  f"distance falls in {sig['rises']:.2f} of {sig['pairs']} step pairs "
                  f"({sig['flat_zero']:.2f}: F = 0 at both ends)")  # fmt: skip
    print()
    print(pair_table(results).to_markdown())
    return 0


def cmd_servo_compare(args) -> int:
    """Two ``servo-eval --out`` files compared episode by episode
    (``servo.task.paired_comparison``)."""
    from dataclasses import asdict

    from servo.task import compare, load_results, markdown

    a, b = load_results(args.a, "A"), load_results(args.b, "B")
    rows = compare(a, b)
    if not rows:
        raise ValueError("A and B share no world and setting (world, tier, split, randomize, "
                         "odometry noise, max steps)")  # fmt: skip
    if args.json:
        print(json.dumps([asdict(r) for r in rows], indent=2))
        return 0
    for name, path, results in (("A", args.a, a), ("B", args.b, b)):
        print(f"{name}: {path} (policy {results[0].get('policy', 'not recorded')})")
    print()
    print(markdown(rows))
    return 0


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The ``topomap`` parser. With ``command``, the subcommands whose options are declared
    by a heavy module (``reproduce``, ``group-eval``: scikit-learn, the experiments) get
    them only if they are ``command`` ("": neither); the others list them all, so ``topomap
    --help`` need not import every experiment (it took ~3 s)."""
    from scenes import WORLDS
    from scripts.collect_command import add_parser as add_collect_parser
    from servo.task import POLICIES

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
    i.add_argument("--scan-topic", default=None,
                   help="sensor_msgs/LaserScan topic; leave out for a robot without a laser "
                   "(camera and odometry only)")  # fmt: skip
    i.add_argument("--image-topic", default=None,
                   help="sensor_msgs/Image or CompressedImage; leave out for a robot without a "
                   "camera (laser and odometry only)")  # fmt: skip
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
    w.add_argument("--world", choices=(*WORLDS, "all"), default="all")
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

    e = sub.add_parser("servo-eval", help="closed-loop servoing between manifolds")
    e.add_argument("--world", choices=(*WORLDS, "all"), default="all")
    e.add_argument(
        "--episodes", type=positive_int, default=100, help="per world (the headline tables: 100)"
    )
    e.add_argument("--tier", default="view", help="start tier: view or anywhere")
    e.add_argument("--split", default="dev", help="episode split: dev (tuning) or test")
    e.add_argument("--policy", type=policy_name, default="servo",
                   help=f"one of {', '.join(POLICIES)}, or package.module:factory (its module "
                   "is imported, running its code, as python -m does)")  # fmt: skip
    e.add_argument("--policy-arg", type=policy_arg, action="append", metavar="KEY=VALUE",
                   help="a keyword argument of the factory (repeatable; JSON values)")  # fmt: skip
    e.add_argument("--max-steps", type=positive_int, default=600)
    e.add_argument("--workers", type=positive_int, default=None, help="default: the cores")
    e.add_argument("--randomize", action="store_true", help="random lights and colours per episode")
    e.add_argument("--no-odometry-noise", action="store_true", help="perfect wheel odometry")
    e.add_argument("--data", default=f"{DEFAULT_OUT}/dataset", help="dataset the map is built from")
    e.add_argument("--maps", default=f"{DEFAULT_OUT}/servo-maps", help="servo map cache")
    e.add_argument("--out", default=None, help="write the results' JSON here")
    e.add_argument("--json", action="store_true", help="print the results as JSON")
    e.set_defaults(func=cmd_servo_eval)

    sc = sub.add_parser("servo-compare", help="two servo-eval results, episode by episode")
    sc.add_argument("a", help="results JSON of servo-eval --out (the reference)")
    sc.add_argument("b", help="results JSON of servo-eval --out (compared with A)")
    sc.add_argument("--json", action="store_true", help="print the comparison as JSON")
    sc.set_defaults(func=cmd_servo_compare)

    from scripts.sweep import add_parser as add_sweep_parser

    add_sweep_parser(sub, default_out=DEFAULT_OUT)
    if command in (None, "leaderboard"):  # scipy loads only for this command
        from scripts.leaderboard import leaderboard_parser

        leaderboard_parser(sub, LEADERBOARD_HELP)
    else:
        sub.add_parser("leaderboard", help=LEADERBOARD_HELP)
    p.description = f"{SUMMARY}\n\ncommands:\n{command_listing(sub)}"
    return p


def command_listing(sub: argparse.Action) -> str:
    """One line per subcommand registered on the subparsers action ``sub``, in the order
    registered: its name, then the ``help=`` it was added with (blank without one)."""
    # argparse keeps each help= in _choices_actions (what its own listing reads; no public
    # accessor) and leaves out a subcommand added without one: the names come from choices
    helps = {a.dest: a.help for a in sub._choices_actions}
    names = list(sub.choices)
    width = max(map(len, names))
    return "\n".join(f"  {name:<{width}}  {helps.get(name) or ''}".rstrip() for name in names)


def _os_message(err: OSError) -> str:
    """One line for an OSError: what failed on which path (``str(err)`` already names the
    path for the errors ``open`` and ``mkdir`` raise)."""
    text = str(err) or type(err).__name__
    return text if err.filename is not None else f"{type(err).__name__}: {text}"


def main(argv: list[str] | None = None) -> int:
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
