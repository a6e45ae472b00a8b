"""``python -m scripts.results``: README's Results table and the results pages.

The table and the pages under ``docs/results/`` are generated from the committed result files
under ``docs/results/data/`` (the rows in ``rows``, read by ``sources``, written by ``render``).
"""

from common.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "PAGES": "scripts.results.rows",
        "ROWS": "scripts.results.rows",
        "SECTIONS": "scripts.results.rows",
        "Estimate": "scripts.results.sources",
        "read_estimate": "scripts.results.sources",
        "generate": "scripts.results.render",
        "leaderboard_inputs": "scripts.results.render",
        "main": "scripts.results.render",
        "readme_table": "scripts.results.render",
    },
)
