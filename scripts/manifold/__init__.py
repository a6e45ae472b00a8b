"""``topomap reproduce`` (the manifold-clustering paper's experiments, ``reproduce``) and the
frozen multi-seed protocol (``python -m scripts.manifold.protocol``), both scoring the methods
of ``methods``.
"""

from common.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "METHODS": "scripts.manifold.methods",
        "bootstrap_mean": "scripts.manifold.methods",
        "score_methods": "scripts.manifold.methods",
        "FEATURES": "scripts.manifold.protocol",
        "load_cells": "scripts.manifold.protocol",
        "summarize": "scripts.manifold.protocol",
        "protocol_markdown": "scripts.manifold.protocol:markdown",
        "run_reproduction": "scripts.manifold.reproduce:reproduce",
        "reproduce_command": "scripts.manifold.reproduce:run",
        "reproduce_parser": "scripts.manifold.reproduce:build_parser",
    },
)
