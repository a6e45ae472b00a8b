"""Result files, methods from outside the repository, and ``topomap leaderboard``.

Result files every evaluation writes (``files``: what ran, on what, by which protocol
version, the per-seed or per-episode records), methods from outside the repository
(``outside``: ``package.module:Class`` and its ``--param``) and ``topomap leaderboard``
(``ranking``: per task and protocol, intervals and paired tests against a reference).
"""

from common.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "FORMAT": "scripts.leaderboard.files",
        "FORMAT_VERSION": "scripts.leaderboard.files",
        "ResultFileError": "scripts.leaderboard.files",
        "envelope": "scripts.leaderboard.files",
        "file_tag": "scripts.leaderboard.files",
        "read_result": "scripts.leaderboard.files",
        "write_result": "scripts.leaderboard.files",
        "OutsideMethod": "scripts.leaderboard.outside",
        "load_method": "scripts.leaderboard.outside",
        "parse_params": "scripts.leaderboard.outside",
        "leaderboard_html": "scripts.leaderboard.ranking",
        "leaderboard_markdown": "scripts.leaderboard.ranking",
        "leaderboard_tables": "scripts.leaderboard.ranking",
        "leaderboard_parser": "scripts.leaderboard.ranking:add_parser",
        "load_results": "scripts.leaderboard.ranking",
        "rank": "scripts.leaderboard.ranking",
        "servo_result_file": "scripts.leaderboard.servo_file",
        "servo_results_of": "scripts.leaderboard.servo_file",
    },
)
