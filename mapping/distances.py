"""Pairwise squared distances, the input of every affinity in ``mapping``.

The manifold method's kernel (Grudic & Mulligan, Section II-A), the spectral baselines, the
label-free variants and the image similarity graph all start from `squared_distances`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["TINY", "squared_distances"]

# Degrees and norms below this are treated as zero: a point with no neighbour at this sigma.
TINY = 1e-300


def squared_distances(A: ArrayLike, B: ArrayLike | None = None) -> np.ndarray:
    """Return squared Euclidean distances between the rows of A and B, in float64.

    Uses ``|a|^2 + |b|^2 - 2 a.b`` (one BLAS product) after centring both on A's mean, which
    keeps the cancellation error small for near-duplicate rows; negatives from round-off are
    clipped to 0 and, when ``B is None``, the diagonal is exactly 0.

    Parameters
    ----------
    A : array-like of shape (n, d)
        First points.
    B : array-like of shape (m, d), optional
        Second points; default A.

    Returns
    -------
    ndarray of shape (n, m)
        ``|A_i - B_j|^2``; symmetric when ``B is None``.
    """
    A = np.asarray(A, dtype=np.float64)
    same = B is None
    B = A if same else np.asarray(B, dtype=np.float64)
    mean = A.mean(axis=0)
    A = A - mean
    B = A if same else B - mean
    sq_a = np.einsum("ij,ij->i", A, A)
    sq_b = sq_a if same else np.einsum("ij,ij->i", B, B)
    D2 = sq_a[:, None] + sq_b[None, :] - 2.0 * (A @ B.T)
    np.maximum(D2, 0.0, out=D2)
    if same:
        np.fill_diagonal(D2, 0.0)
        # Symmetrise: the two triangles differ in the last bit after the BLAS product.
        D2 = 0.5 * (D2 + D2.T)
    return D2
