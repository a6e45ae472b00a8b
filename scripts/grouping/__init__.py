"""``topomap group-eval``: the observation grouping on simulated worlds and real logs.

The observation grouping on the simulated worlds (``evaluate``, scored by ``scores``, tabled
by ``tables``, drawn by ``plots``), its local maps (``local_maps``), the real Carmen logs
(``carmen_logs``) and the loop recordings it groups (``loop_recordings``).
"""

from common.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "carmen_eval": "scripts.grouping.carmen_logs:run",
        "carmen_report": "scripts.grouping.carmen_logs:format_report",
        "evaluate_carmen": "scripts.grouping.carmen_logs",
        "log_points": "scripts.grouping.carmen_logs",
        "evaluate_grouping": "scripts.grouping.evaluate",
        "group_eval": "scripts.grouping.evaluate:run",
        "group_eval_parser": "scripts.grouping.evaluate:build_parser",
        "one_dataset": "scripts.grouping.evaluate",
        "local_maps_eval": "scripts.grouping.local_maps:run",
        "collect_loop": "scripts.grouping.loop_recordings",
        "agg_pyplot": "scripts.grouping.plots",
        "save_figure": "scripts.grouping.plots",
        "score_groups": "scripts.grouping.scores",
        "comparison_table": "scripts.grouping.tables",
        "grouping_table": "scripts.grouping.tables",
    },
)
