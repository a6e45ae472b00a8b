"""Deprecated home of :func:`common.fileio.atomic_write_bytes`, kept only until the callers not
yet moved (``scripts/sweep.py``) import it from :mod:`common.fileio`; use that."""

from common.fileio import atomic_write_bytes

__all__ = ["atomic_write_bytes"]
