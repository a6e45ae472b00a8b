"""The result file of ``topomap servo-eval --out``.

The evaluation's own results (``results``, one entry per world, unchanged) inside the
envelope of ``scripts.leaderboard.files``, with one record per episode (success or not) for
the leaderboard.
"""

from __future__ import annotations

from common.user_modules import source_digest
from scripts.leaderboard.files import envelope

__all__ = ["PROTOCOL", "TASK", "servo_method", "servo_result_file", "servo_results_of"]

TASK = "servo"
# name and version of the closed-loop protocol (servo.task.Protocol) in result files; the
# version goes up whenever a change alters the episodes or their success test
PROTOCOL = ("servo-closed-loop", 1)


def _group(result: dict) -> str:
    extras = [
        name
        for name, on in (
            ("randomize", result.get("randomize")),
            ("no odometry noise", result.get("odometry_noise") is False),
        )
        if on
    ]
    steps = result.get("max_steps")
    return "/".join(
        [
            str(result["world"]),
            str(result["tier"]),
            *extras,
            *([f"{steps} steps"] if steps not in (None, 600) else []),
        ]
    )


def servo_result_file(results: list[dict], policy: str, split: str) -> dict:
    """Wrap servo-eval ``results`` in a result file's envelope, one record per episode.

    The envelope keeps ``results`` as they are under ``results``.

    Parameters
    ----------
    results : list of dict
        ``servo.task.run_protocol``'s dicts, one per world.
    policy : str
        The policy's name (``servo.task.POLICIES``) or ``package.module:factory`` spec.
    split : str
        The split evaluated on.

    Returns
    -------
    dict
        The result file's object (an [`envelope`][scripts.leaderboard.files.envelope]).
    """
    records = [
        {
            "group": _group(r),
            "unit": f"episode {e['episode']}",
            "seed": e.get("seed"),
            "value": bool(e["success"]),
            "failure": None,
        }
        for r in results
        for e in r.get("episodes_detail", [])
    ]
    return envelope(
        TASK,
        PROTOCOL,
        split,
        servo_method(results, policy),
        ("success", "rate"),
        records,
        results=results,
    )


def servo_method(results: list[dict], policy: str) -> dict:
    """Build the ``method`` of a servo result file.

    A built-in policy is given by its name (``servo.task.POLICIES``), an outside one by its
    ``package.module:factory`` spec, named by its module's last part, with the
    ``--policy-arg`` parameters its results record, whether its process ran in a sandbox
    (``sandboxed``) and its source's digest (``source``).

    Parameters
    ----------
    results : list of dict
        ``servo.task.run_protocol``'s dicts, one per world.
    policy : str
        The policy's name or ``package.module:factory`` spec.

    Returns
    -------
    dict
        The method block: ``name``, ``spec``, ``params`` and, for an outside policy,
        ``sandboxed`` and ``source``.
    """
    policy = str(policy)
    params = next(
        (r["policy_params"] for r in results if isinstance(r.get("policy_params"), dict)), {}
    )
    if ":" not in policy:
        return {"name": policy, "spec": f"servo.task.POLICIES:{policy}", "params": params}
    module = policy.split(":", 1)[0]
    where = next((r["isolation"] for r in results if isinstance(r.get("isolation"), dict)), {})
    source = next((r["source"] for r in results if isinstance(r.get("source"), dict)), None)
    return {
        "name": module.rsplit(".", 1)[-1],
        "spec": policy,
        "params": params,
        "sandboxed": bool(where.get("sandboxed", False)),
        "source": source or source_digest(module),
    }


def servo_results_of(data):
    """Return the servo-eval results in ``data`` as read from a file.

    Parameters
    ----------
    data : object
        A file's parsed content.

    Returns
    -------
    object
        A result file's ``results``, or ``data`` itself (files written before the envelope:
        a list, or one object).
    """
    if isinstance(data, dict) and data.get("format") == "topomap-result":
        return data.get("results")
    return data
