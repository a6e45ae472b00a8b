"""The manifold-clustering experiments: ``topomap reproduce``, the protocol, ``manifold-eval``.

``topomap reproduce`` (the manifold-clustering paper's experiments, ``reproduce``), the
frozen multi-seed protocol (``python -m scripts.manifold.protocol``), both scoring the methods
of ``methods``, and ``topomap manifold-eval`` (any clusterer through that protocol,
``outside``).
"""

from common.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "METHODS": "scripts.manifold.methods",
        "OURS": "scripts.manifold.methods",
        "SKLEARN_DEFAULT": "scripts.manifold.methods",
        "bootstrap_mean": "scripts.manifold.methods",
        "score_methods": "scripts.manifold.methods",
        "FEATURES": "scripts.manifold.protocol",
        "load_cells": "scripts.manifold.protocol",
        "summarize": "scripts.manifold.protocol",
        "protocol_markdown": "scripts.manifold.protocol:markdown",
        "PROTOCOL": "scripts.manifold.protocol",
        "evaluate_method": "scripts.manifold.outside",
        "manifold_eval_parser": "scripts.manifold.outside:add_parser",
        "run_reproduction": "scripts.manifold.reproduce:reproduce",
        "reproduce_command": "scripts.manifold.reproduce:run",
        "reproduce_parser": "scripts.manifold.reproduce:build_parser",
    },
)
