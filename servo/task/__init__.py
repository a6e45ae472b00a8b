"""The servo task and how it is measured.

The subpackage holds the env (``env``, registered by ``registration``), the closed-loop evaluation
(``evaluation``), the frozen benchmark protocol (``protocol``), the policies it can run
(``policies``: their names; ``baseline_policies``: random, greedy F probing and the oracle), what a
policy under evaluation is and is given (``interface``: the [`Policy`][servo.task.interface.Policy]
interface, its factory, the target and the map as sensed), its calls guarded (``guard``: an error, a
bad action or a slow step fails the episode), an outside policy in its own process (``remote``,
``policy_host``, their messages ``wire``; the runner's worker ``worker``), two evaluations paired
episode by episode (``paired_comparison``) and the Wilson interval of a success rate (``stats``).
"""

from common.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "GreedyFProbing": "servo.task.baseline_policies",
        "OraclePolicy": "servo.task.baseline_policies",
        "RandomPolicy": "servo.task.baseline_policies",
        "ServoEnv": "servo.task.env",
        "episode_seeds": "servo.task.evaluation",
        "evaluate": "servo.task.evaluation",
        "make_policy": "servo.task.evaluation",
        "plot_trajectories": "servo.task.evaluation",
        "run_episode": "servo.task.evaluation",
        "summarise": "servo.task.evaluation",
        "ACT_LIMIT_S": "servo.task.guard",
        "FAILURES": "servo.task.guard",
        "PolicyFailure": "servo.task.guard",
        "Policy": "servo.task.interface",
        "PolicyFactory": "servo.task.interface",
        "PolicyLoadError": "servo.task.interface",
        "Target": "servo.task.interface",
        "load_factory": "servo.task.interface",
        "make_outside_policy": "servo.task.interface",
        "sensed_map": "servo.task.interface",
        "PairedComparison": "servo.task.paired_comparison",
        "compare": "servo.task.paired_comparison",
        "load_results": "servo.task.paired_comparison",
        "markdown": "servo.task.paired_comparison",
        "POLICIES": "servo.task.policies",
        "RemotePolicy": "servo.task.remote",
        "sandbox_tool": "servo.task.remote",
        "TRUTH_POLICY": "servo.task.policies",
        "SUCCESS_TARGETS": "servo.task.protocol",
        "TIERS": "servo.task.protocol",
        "EpisodeSpec": "servo.task.protocol",
        "Protocol": "servo.task.protocol",
        "episode_specs": "servo.task.protocol",
        "manifold_pairs": "servo.task.protocol",
        "reset_options": "servo.task.protocol",
        "run_protocol": "servo.task.protocol",
        "MAX_EPISODE_STEPS": "servo.task.registration",
        "TruncationReason": "servo.task.registration",
        "register_envs": "servo.task.registration",
        "WILSON_Z": "servo.task.stats",
        "wilson_interval": "servo.task.stats",
    },
)
