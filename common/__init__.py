"""Pieces every layer shares, below ``scenes``.

SE(2) pose algebra and scan geometry (`common.geometry`), atomic file writes and JSON
coercion (`common.fileio`), argument checks (`common.validation`), the physical bounds every
reader checks data against (`common.bounds`), untrusted ``.npz`` files read safely
(`common.npz`), the BLAS thread policy (`common.blas`), the cores this process may use
(`common.cores`) and the lazy package faces (`common.lazy`), and a user's own module imported
as ``python -m`` would (`common.user_modules`).

numpy, threadpoolctl and the standard library only; nothing here imports another package of the
project, so each layer above may use it.
"""
