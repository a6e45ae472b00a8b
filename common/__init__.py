"""Pieces every layer shares, below ``scenes``: SE(2) pose algebra and scan geometry
(:mod:`common.geometry`), atomic file writes and JSON coercion (:mod:`common.fileio`).

Pure numpy and the standard library; nothing here imports another package of the project, so
each layer above may use it.
"""
