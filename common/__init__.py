"""Pieces every layer shares, below ``scenes``: SE(2) pose algebra and scan geometry
(:mod:`common.geometry`), atomic file writes and JSON coercion (:mod:`common.fileio`), argument
checks (:mod:`common.validation`), the physical bounds every reader checks data against
(:mod:`common.bounds`), untrusted ``.npz`` files read safely (:mod:`common.npz`), the BLAS
thread policy (:mod:`common.blas`), the cores this process may use (:mod:`common.cores`) and
the lazy package faces (:mod:`common.lazy`), and a user's own module imported as
``python -m`` would (:mod:`common.user_modules`).

numpy, threadpoolctl and the standard library only; nothing here imports another package of the
project, so each layer above may use it.
"""
