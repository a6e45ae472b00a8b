"""The runner's worker: one env and one policy per worker process.

``run_protocol`` spawns the workers, or runs one in its own process; the policy runs in the
worker or in a process of its own (``servo.task.remote``).
"""

from __future__ import annotations

import numpy as np

from servo.task.policies import TRUTH_POLICY

_WORKER: dict = {}


def param_names(options) -> list[str]:
    """Return the names a policy's params may have.

    The names must be identifiers (they become keyword arguments); the values go to the
    policy, which checks them.

    Parameters
    ----------
    options : dict or None
        The policy's params.

    Returns
    -------
    list of str
        The keys of ``options`` (none where it is not a dict).
    """
    if isinstance(options, dict):
        bad = [k for k in options if not (isinstance(k, str) and k.isidentifier())]
        if bad:
            raise ValueError(f"policy_options keys must be identifiers, got {bad[0]!r}")
        return list(options)
    return []


def init_worker(
    protocol,
    map_path: str,
    policy: str,
    options: dict,
    seed: int = 0,
    act_limit_s: float | None = None,
    isolation: dict | None = None,
    reset_options=None,
) -> None:
    """Make this worker's env and policy (``run_protocol``'s pool initializer).

    Parameters
    ----------
    protocol : Protocol
        The benchmark cell (its world and env settings).
    map_path : str
        The saved map's path.
    policy : str
        A policy name or an outside factory ``package.module:factory``.
    options : dict
        The policy's params.
    seed : int, default 0
        The policy seed.
    act_limit_s : float, optional
        Seconds a policy's call may take (default ``servo.task.guard.ACT_LIMIT_S``).
    isolation : dict, optional
        The policy runs in its own process where ``isolation["process"]`` (sandboxed where
        ``isolation["sandboxed"]``, its ``hide`` folders emptied), else here; default: an
        outside policy in its own process, unsandboxed.
    reset_options : callable, optional
        ``servo.task.protocol.reset_options`` (passed in: that module imports this one).
    """
    import sim  # noqa: F401  (the GL backend before mujoco, in a spawned process)
    from servo.task.env import ServoEnv
    from servo.task.evaluation import make_policy
    from servo.task.guard import ACT_LIMIT_S
    from servo.task.interface import PolicyLoadError, is_policy_spec
    from servo.task.remote import RemotePolicy

    env = ServoEnv(
        protocol.world,
        map_path,
        max_steps=protocol.max_steps,
        randomize=protocol.randomize,
        odometry_noise=protocol.odometry_noise,
    )
    isolation = isolation or {"process": is_policy_spec(policy), "sandboxed": False, "hide": []}
    pol, load_error, rng = None, None, np.random.default_rng(seed)
    try:  # in its own process (an outside policy always), or ours in this one
        if isolation["process"]:
            pol = RemotePolicy(
                policy,
                env.map,
                seed,
                options,
                sandbox=isolation["sandboxed"],
                hide=isolation["hide"],
            )
        else:
            pol = make_policy(policy, env, rng, **options)
    except PolicyLoadError as err:  # every episode fails with the reason; the run goes on
        load_error = str(err)
    # a slow policy of ours (greedy probing) gets the steps to cover the route: it measures F
    # then. An outside policy gets the protocol's steps, whatever it claims.
    if not is_policy_spec(policy):
        ours = pol  # in its own process: its steps as our in-process one would have them
        if isolation["process"] and policy.startswith("greedy"):
            ours = make_policy(policy, env, np.random.default_rng(seed), **options)
        env.max_steps = protocol.max_steps * int(getattr(ours, "budget_factor", 1))
    limit = ACT_LIMIT_S if act_limit_s is None else float(act_limit_s)
    # an outside policy's generator is set anew for every episode (interface.reseed); ours
    # keep the one generator of the worker, as their published numbers were made with it
    # the protocol's reset options (servo.task.protocol.reset_options), passed in: this module
    # is imported by the protocol's, not the other way round
    _WORKER.update(
        reset_options=reset_options,
        env=env,
        protocol=protocol,
        policy=pol,
        load_error=load_error,
        truth=policy == TRUTH_POLICY,
        act_limit_s=limit,
        policy_seed=seed,
        rng=rng if is_policy_spec(policy) else None,
    )


def close_worker() -> None:
    """End this worker's env and policy process (the in-process runner's end)."""
    _WORKER.pop("env").close()
    policy = _WORKER.pop("policy", None)
    if hasattr(policy, "close"):
        policy.close()


def run_spec(spec) -> dict:
    """Run episode ``spec`` in this worker and return its record.

    Parameters
    ----------
    spec : EpisodeSpec
        The episode (a ``servo.task.EpisodeSpec``).

    Returns
    -------
    dict
        The episode's record, with ``episode`` its index.
    """
    from servo.task.evaluation import run_episode
    from servo.task.interface import reseed

    env, protocol, policy = _WORKER["env"], _WORKER["protocol"], _WORKER["policy"]
    if _WORKER["rng"] is not None:
        if hasattr(policy, "set_episode"):  # its generator lives in its own process
            policy.set_episode(spec.seed, _WORKER["policy_seed"])
        else:
            reseed(_WORKER["rng"], spec.seed, _WORKER["policy_seed"])
    record = run_episode(
        env,
        policy,
        spec.seed,
        _WORKER["reset_options"](env, spec, protocol.tier),
        truth=_WORKER["truth"],
        act_limit_s=_WORKER["act_limit_s"],
        load_error=_WORKER["load_error"],
    )
    record["episode"] = spec.index
    return record


def isolation_of(policy: str, isolate, sandbox) -> dict:
    """Decide where the policy runs.

    Parameters
    ----------
    policy : str
        A policy name or an outside factory ``package.module:factory``.
    isolate : bool or None
        Run it in its own process; None: an outside policy does, ours do not.
    sandbox : bool or None
        Run that process in a sandbox; None: where the platform has one.

    Returns
    -------
    dict
        ``process`` (its own), ``sandboxed``, ``sandbox`` (the tool).
    """
    from servo.task.interface import is_policy_spec
    from servo.task.remote import sandbox_tool

    process = is_policy_spec(policy) if isolate is None else bool(isolate)
    if is_policy_spec(policy) and not process:
        raise ValueError("an outside policy runs in its own process: isolate=False is refused")
    if process and policy == TRUTH_POLICY:
        raise ValueError("the oracle is given the env's truth: it runs in the worker only")
    tool = sandbox_tool() if process and sandbox is not False else None
    if sandbox and not process:
        raise ValueError("sandbox=True needs the policy in its own process (isolate)")
    if sandbox and tool is None:
        raise ValueError("sandbox=True, but neither bwrap nor unshare can make a sandbox here")
    return {"process": process, "sandboxed": tool is not None, "sandbox": tool}
