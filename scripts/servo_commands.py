"""The ``topomap servo-eval`` and ``topomap servo-compare`` commands.

``topomap servo-eval`` runs the closed-loop benchmark protocol, ours or an outside policy;
``topomap servo-compare`` compares two of its result files, episode by episode.
"""

from __future__ import annotations

import hashlib
import json
import sys

from scripts.args import (
    WORLD_HELP,
    output_folder,
    policy_arg,
    policy_name,
    positive_int,
    world_choice,
    worlds,
)
from scripts.data_needed import DEFAULT_DATA, ensure_dataset


def servo_eval_name(args) -> str:
    """Name the results file of ``servo-eval --out``.

    Every setting that changes the episodes is in the name, so runs of other worlds or settings
    into one folder do not overwrite each other.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of ``topomap servo-eval``.

    Returns
    -------
    str
        The file name.
    """
    extras = "-randomize" * bool(args.randomize) + "-no-odometry-noise" * bool(
        args.no_odometry_noise
    )
    steps = "" if args.max_steps == 600 else f"-{args.max_steps}steps"
    # an outside policy: its spec with ':' as '.', and its params' digest (runs differ by them)
    params = dict(args.policy_arg or [])
    digest = hashlib.sha256(json.dumps(params, sort_keys=True).encode()).hexdigest()[:8]
    tag = args.policy.replace(":", ".") + (f"-{digest}" if params else "")
    return (
        f"servo-eval-{args.world.replace(':', '-')}-{args.tier}-{args.split}-{tag}"
        f"-{args.episodes}ep{extras}{steps}.json"
    )


def cmd_servo_eval(args) -> int:
    """Run the closed-loop servo evaluation by the benchmark protocol (``servo.task.protocol``).

    One start tier and split, in one world or both, episodes in parallel over the cores;
    ``--policy`` one of ours or an outside factory ``package.module:factory`` with
    ``--policy-arg``s.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of ``topomap servo-eval``.

    Returns
    -------
    int
        The exit status: 0, or 2 when ``--sandbox on`` finds no sandbox tool.
    """
    from servo.maps import load_or_build, map_paths
    from servo.task import Protocol, run_protocol

    out = output_folder(args.out) if args.out else None
    sandbox = {"auto": None, "on": True, "off": False}[getattr(args, "sandbox", "auto")]
    if ":" not in args.policy:
        sandbox = None  # ours run in the worker
    elif sandbox:
        from servo.task import sandbox_tool

        if sandbox_tool() is None:
            print(
                "topomap servo-eval: --sandbox on, but neither bwrap nor unshare can make a "
                "sandbox on this machine",
                file=sys.stderr,
            )
            return 2
    data = ensure_dataset(args.data or DEFAULT_DATA, "servo-eval", progress=not args.json)
    results = []
    for world in worlds(args.world):
        protocol = Protocol(
            world,
            args.tier,
            args.split,
            randomize=args.randomize,
            odometry_noise=not args.no_odometry_noise,
            max_steps=args.max_steps,
        )
        servo_map = load_or_build(world, dataset=data, cache=args.maps)
        path, _ = map_paths(args.maps, world, servo_map.key)
        r = run_protocol(
            protocol,
            path if path.is_file() else servo_map,
            args.episodes,
            args.policy,
            workers=args.workers,
            progress=not args.json,
            policy_options=dict(args.policy_arg or []),
            hide=[data],
            sandbox=sandbox,
        )
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
            print(
                f"{r['world']} {r['policy']}: F toward the target rises as the true "
                f"distance falls in {sig['rises']:.2f} of {sig['pairs']} step pairs "
                f"({sig['flat_zero']:.2f}: F = 0 at both ends)"
            )
    print()
    print(pair_table(results).to_markdown())
    return 0


def cmd_servo_compare(args) -> int:
    """Compare two ``servo-eval --out`` files episode by episode (``servo.task.paired_comparison``).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of ``topomap servo-compare``.

    Returns
    -------
    int
        The exit status, 0.

    Raises
    ------
    ValueError
        If the files share no world and setting.
    """
    from dataclasses import asdict

    from servo.task import compare, load_results, markdown

    a, b = load_results(args.a, "A"), load_results(args.b, "B")
    rows = compare(a, b)
    if not rows:
        raise ValueError(
            "A and B share no world and setting (world, tier, split, randomize, "
            "odometry noise, max steps)"
        )
    if args.json:
        print(json.dumps([asdict(r) for r in rows], indent=2))
        return 0
    for name, path, results in (("A", args.a, a), ("B", args.b, b)):
        print(f"{name}: {path} (policy {results[0].get('policy', 'not recorded')})")
    print()
    print(markdown(rows))
    return 0


def add_parsers(sub, default_out: str) -> None:
    """Add the ``servo-eval`` and ``servo-compare`` subcommands to the subparsers ``sub``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subparsers of the ``topomap`` parser.
    default_out : str
        The folder of the data and maps by default.
    """
    from servo.task import POLICIES

    e = sub.add_parser("servo-eval", help="closed-loop servoing between manifolds")
    e.add_argument("--world", type=world_choice, default="all", metavar="WORLD", help=WORLD_HELP)
    e.add_argument(
        "--episodes", type=positive_int, default=100, help="per world (the headline tables: 100)"
    )
    e.add_argument("--tier", default="view", help="start tier: view or anywhere")
    e.add_argument("--split", default="dev", help="episode split: dev (tuning) or test")
    e.add_argument(
        "--policy",
        type=policy_name,
        default="servo",
        help=f"one of {', '.join(POLICIES)}, or package.module:factory (its module "
        "is imported, running its code, as python -m does)",
    )
    e.add_argument(
        "--policy-arg",
        type=policy_arg,
        action="append",
        metavar="KEY=VALUE",
        help="a keyword argument of the factory (repeatable; JSON values)",
    )
    e.add_argument("--max-steps", type=positive_int, default=600)
    e.add_argument("--workers", type=positive_int, default=None, help="default: the cores")
    e.add_argument("--randomize", action="store_true", help="random lights and colours per episode")
    e.add_argument("--no-odometry-noise", action="store_true", help="perfect wheel odometry")
    e.add_argument(
        "--data",
        default=None,
        help=f"dataset the map is built from (default {DEFAULT_DATA}, collected there "
        "when missing)",
    )
    e.add_argument("--maps", default=f"{default_out}/servo-maps", help="servo map cache")
    e.add_argument("--out", default=None, help="write the results' JSON here")
    e.add_argument(
        "--sandbox",
        choices=("auto", "on", "off"),
        default="auto",
        help="an outside policy's process in a sandbox (bwrap or unshare) that "
        "hides the datasets and maps: where the platform has one (auto), always "
        "(on: refused where there is none) or never (off); recorded",
    )
    e.add_argument("--json", action="store_true", help="print the results as JSON")
    e.set_defaults(func=cmd_servo_eval)

    sc = sub.add_parser("servo-compare", help="two servo-eval results, episode by episode")
    sc.add_argument("a", help="results JSON of servo-eval --out (the reference)")
    sc.add_argument("b", help="results JSON of servo-eval --out (compared with A)")
    sc.add_argument("--json", action="store_true", help="print the comparison as JSON")
    sc.set_defaults(func=cmd_servo_compare)
