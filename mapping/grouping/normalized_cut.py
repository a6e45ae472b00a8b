"""Recursive minimum-normalised-cut partition of a weighted graph (Blanco et al., Section II).

The functional core of the observation grouping; it works on any symmetric non-negative weight
matrix (dense or ``scipy.sparse``): ``ncut`` is eq. 1, ``spectral_bisection`` solves eq. 10-11
and splits the second eigenvector at its mean, ``recursive_ncut_partition`` applies the
bisection while the cut is accepted (eq. 12-13, Section II-B). ``mapping.grouping.partitioner``
holds the laser-scan estimator built on it (Sections III-IV).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg
from numpy.typing import ArrayLike
from scipy.sparse.csgraph import connected_components

from common.blas import single_threaded_blas
from mapping.split_tree import SplitNode

__all__ = [
    "NcutNode",
    "ncut",
    "recursive_ncut_partition",
    "spectral_bisection",
]

ASSOC = ("mrpt", "paper")
LAPLACIAN = ("normalized", "unnormalized")
SOLVERS = ("auto", "dense", "sparse")
# Below this many nodes a dense eigendecomposition (LAPACK's MRRR for the one eigenvector, one
# BLAS thread) beats the sparse solvers: LOBPCG took 160 ms per bisection of the 440-scan ACES
# log, LAPACK 18 ms; above it the dense O(n^3) solve dominates (bench/bench_partition.py).
DENSE_MAX_NODES = 1000
# Up to this many nodes the recursion indexes subgraphs out of one dense copy of W (32 MB):
# fancy indexing of a dense array is ~10x cheaper than of a CSR matrix.
DENSE_INDEX_MAX_NODES = 2048
# Shift for the shift-invert Lanczos: just below the zero eigenvalue of the Laplacian.
_SHIFT = -1e-3
# LOBPCG: iterations, and the residual ||L z - lambda z|| above which ARPACK takes over.
_LOBPCG_MAXITER = 200
_LOBPCG_RESIDUAL = 1e-6
# Weights above this are divided by the largest one before the degrees are summed: the Ncut
# and the bisection do not depend on the scale of W, and n weights near the float maximum
# would overflow the degree sum. Below it W is used as given (bit for bit as before).
RESCALE_ABOVE = 1e100


def check_weights(W: ArrayLike | sp.sparray, name: str = "W") -> np.ndarray | sp.csr_array:
    """Return ``W`` as float ndarray or csr_array after checking it is a valid graph.

    Parameters
    ----------
    W : array-like or sparse matrix of shape (n, n)
        Weights; must be square, finite, non-negative and symmetric.
    name : str, default "W"
        Name of the argument, for the error messages.

    Returns
    -------
    ndarray or scipy.sparse.csr_array of shape (n, n)
        ``W`` as floats (sparse stays sparse).
    """
    if sp.issparse(W):
        W = sp.csr_array(W, dtype=float)
        values = W.data
    else:
        W = np.asarray(W, dtype=float)
        values = W
    if W.ndim != 2 or W.shape[0] != W.shape[1]:
        raise ValueError(f"{name} must be a square matrix, got shape {W.shape}")
    if not np.isfinite(values).all():
        raise ValueError(f"{name} contains NaN or inf")
    if (values < 0).any():
        raise ValueError(f"{name} must be non-negative (weights are overlaps or similarities)")
    # max() of nothing raises numpy's own message; a graph without nodes is for the caller to name
    asym = abs(W - W.T).max() if W.shape[0] else 0.0
    if asym > 1e-9 * max(1.0, abs(values).max(initial=0.0)):
        raise ValueError(f"{name} must be symmetric (max |W - W.T| = {asym:.3g})")
    return W


def _rescaled(W: np.ndarray | sp.csr_array) -> np.ndarray | sp.csr_array:
    """Return ``W / W.max()`` when its largest weight exceeds ``RESCALE_ABOVE``, else ``W``."""
    top = float(W.max()) if W.shape[0] else 0.0
    return W / top if top > RESCALE_ABOVE else W


def _check_solver(solver: str) -> None:
    if solver not in SOLVERS:
        raise ValueError(f"solver must be one of {SOLVERS}, got {solver!r}")


def ncut(W: ArrayLike | sp.sparray, mask: ArrayLike, assoc: str = "mrpt") -> float:
    """Return the normalised cut of the bisection ``A = mask``, ``B = ~mask`` (eq. 1).

    ``Ncut = cut(A, B) / assoc(A, V) + cut(A, B) / assoc(B, V)`` with ``cut`` the summed
    weight between the groups (eq. 2). ``assoc`` selects how the association is counted:

    - ``"mrpt"``: ``assoc(A, V) = cut(A, B) + assoc(A, A)`` (eq. 5) with ``assoc(A, A)`` the
      weight of each unordered pair inside ``A`` counted once, self-weights excluded, the same
      basis as ``cut``. This is MRPT's ``CGraphPartitioner::nCut``.
    - ``"paper"``: eq. 3 as written, ``sum_{u in A, v in V} W_uv``: the degree volume, which
      counts each pair inside ``A`` twice and includes the diagonal.

    Parameters
    ----------
    W : array-like or sparse matrix of shape (n, n)
        Symmetric non-negative weights.
    mask : array-like of bool, shape (n,)
        True for the nodes of ``A``.
    assoc : {"mrpt", "paper"}, default "mrpt"
        How the association is counted.

    Returns
    -------
    float
        0 when ``cut(A, B) = 0`` (two disconnected groups), else a value in ``(0, 2]``.

    Raises
    ------
    ValueError
        If ``mask`` does not have one entry per node, or one side of the bisection is empty.
    """
    if assoc not in ASSOC:
        raise ValueError(f"assoc must be one of {ASSOC}, got {assoc!r}")
    W = check_weights(W)
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != (W.shape[0],):
        raise ValueError(f"mask must have shape ({W.shape[0]},), got {mask.shape}")
    if mask.all() or not mask.any():
        raise ValueError("mask must put at least one node on each side of the bisection")
    return _ncut(_rescaled(W), mask, assoc)


def _ncut(W: np.ndarray | sp.csr_array, mask: np.ndarray, assoc: str) -> float:
    x = mask.astype(float)
    wx = W @ x  # weight from each node into A
    deg = np.asarray(W.sum(axis=1)).ravel()
    vol_a = float(x @ deg)
    within_a = float(x @ wx)  # ordered pairs in A, diagonal included
    cut = vol_a - within_a
    if cut <= 0:
        return 0.0
    vol_b = float(deg.sum()) - vol_a
    if assoc == "paper":  # eq. 3
        return cut / vol_a + cut / vol_b
    diag = W.diagonal()
    # eq. 5 with intra-group pairs once and no self-weights, as in MRPT
    assoc_aa = 0.5 * (within_a - float(x @ diag))
    assoc_bb = 0.5 * (vol_b - cut - float((1.0 - x) @ diag))
    return cut / (cut + assoc_aa) + cut / (cut + assoc_bb)


def spectral_bisection(
    W: ArrayLike | sp.sparray, laplacian: str = "normalized", solver: str = "auto"
) -> tuple[np.ndarray, np.ndarray]:
    """Bisect a graph with the second eigenvector of its Laplacian, split at its mean.

    ``laplacian="normalized"`` solves the generalised eigenproblem ``(D - W) y = lambda D y``
    (eq. 10) through its symmetric form ``D^-1/2 (D - W) D^-1/2 z = lambda z``, ``y = D^-1/2 z``
    (eq. 11), whose second-smallest eigenvector relaxes the min-Ncut problem (eq. 8).
    ``"unnormalized"`` uses ``(D - W) y = lambda y`` as MRPT does. Nodes with ``y >= mean(y)``
    form ``A`` (the paper's choice over the sign, Section II-A).

    A disconnected graph has a multiple zero eigenvalue, so its "second eigenvector" is any
    combination of component indicators; the bisection then separates the connected component
    of node 0 from the rest (a cut of weight 0, the limit the eigenvector approaches).

    Parameters
    ----------
    W : array-like or sparse matrix of shape (n, n)
        Symmetric non-negative weights, ``n >= 2``.
    laplacian : {"normalized", "unnormalized"}
    solver : {"auto", "dense", "sparse"}
        ``"dense"``: LAPACK on the full matrix; ``"sparse"``: LOBPCG on the sparse Laplacian,
        constrained orthogonal to its known null vector (``D^1/2 1``), falling back to ARPACK's
        shift-invert Lanczos if LOBPCG does not converge; ``"auto"``: dense up to
        ``DENSE_MAX_NODES`` nodes. Graphs of fewer than 6 nodes are solved dense whatever the
        choice.

    Returns
    -------
    mask : ndarray of shape (n,), bool
        Membership of ``A``; oriented so that node 0 is in ``A``.
    y : ndarray of shape (n,)
        The eigenvector (the component indicator for a disconnected graph).
    """
    if laplacian not in LAPLACIAN:
        raise ValueError(f"laplacian must be one of {LAPLACIAN}, got {laplacian!r}")
    _check_solver(solver)
    W = check_weights(W)
    if W.shape[0] < 2:
        raise ValueError(f"W must have at least 2 nodes to bisect, got {W.shape[0]}")
    return _bisect(_rescaled(W), laplacian, solver)


def _bisect(W, laplacian: str, solver: str) -> tuple[np.ndarray, np.ndarray]:
    """Run ``spectral_bisection`` without the input checks (the recursion checks ``W`` once)."""
    # a CSR copy: csgraph's own dense input path goes through masked arrays, ~10x slower
    n_comp, comp = connected_components(sp.csr_array(W), directed=False)
    if n_comp > 1:
        y = (comp == comp[0]).astype(float)
        return y > 0.5, y
    deg = np.asarray(W.sum(axis=1)).ravel()
    y = _second_eigenvector(W, deg, laplacian, solver)
    mask = y >= y.mean()
    if not mask[0]:
        mask, y = ~mask, -y
    return mask, y


def _second_eigenvector(W, deg: np.ndarray, laplacian: str, solver: str) -> np.ndarray:
    n = W.shape[0]
    scale = 1.0 / np.sqrt(deg) if laplacian == "normalized" else np.ones(n)
    # LOBPCG with one vector and one constraint needs n - 1 >= 5 nodes: below that scipy
    # switches to a dense solve that refuses constraints (NotImplementedError)
    use_dense = solver == "dense" or (solver == "auto" and n <= DENSE_MAX_NODES) or n < 6
    if use_dense:
        Wd = W.toarray() if sp.issparse(W) else W
        L = np.diag(deg) - Wd
        L = scale[:, None] * L * scale[None, :]  # eq. 11: D^-1/2 (D - W) D^-1/2
        _, z = scipy.linalg.eigh(L, subset_by_index=[1, 1])
        z = z[:, 0]
    else:
        Ws = sp.csr_array(W)
        L = sp.diags_array(deg) - Ws
        L = (sp.diags_array(scale) @ L @ sp.diags_array(scale)).tocsr()
        z = _sparse_second_eigenvector(L, 1.0 / scale)
    return scale * z  # back to y of eq. 10 (identity for the unnormalised Laplacian)


def _sparse_second_eigenvector(L: sp.csr_array, null: np.ndarray) -> np.ndarray:
    """Second-smallest eigenvector of the symmetric Laplacian ``L`` of a connected graph.

    The smallest eigenpair is known (eigenvalue 0, eigenvector ``null``: ``D^1/2 1`` for eq. 11,
    the ones for ``D - W``), so LOBPCG seeks the smallest eigenvector orthogonal to it; it
    needs only products with ``L``, where the shift-invert Lanczos factorises ``L`` (on a
    5000-scan log the factorisations took 3.3 of 5.2 s). The start vector is the trajectory
    order, ``linspace(1, 2, n)``: fixed, so the result is deterministic, and close to the
    answer for scans in time order (the Fiedler vector of a trajectory varies slowly along it).
    A residual above ``_LOBPCG_RESIDUAL`` hands over to ARPACK.
    """
    n = L.shape[0]
    start = np.linspace(1.0, 2.0, n)
    constraint = (null / np.linalg.norm(null))[:, None]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # non-convergence is checked below
        lam, X = scipy.sparse.linalg.lobpcg(
            L, start[:, None], Y=constraint, largest=False, tol=1e-9, maxiter=_LOBPCG_MAXITER
        )
    z = X[:, 0]
    if np.linalg.norm(L @ z - lam[0] * z) <= _LOBPCG_RESIDUAL:
        return z
    _, z = scipy.sparse.linalg.eigsh(L.tocsc(), k=2, sigma=_SHIFT, which="LM", v0=start)
    return z[:, 1]


@dataclass(eq=False)
class NcutNode(SplitNode):
    """A node of the recursive min-Ncut bisection tree.

    Parameters
    ----------
    indices : ndarray of int
        Nodes of the original graph in this subgraph.
    children : tuple of NcutNode, default ()
        The two halves of an accepted bisection; empty for a leaf.
    ncut : float or None, default None
        Ncut of the best bisection found.

    Attributes
    ----------
    indices : ndarray of int
        Nodes of the original graph in this subgraph.
    children : tuple of NcutNode
        The two halves if the bisection was accepted (``ncut < threshold``), else empty.
    ncut : float or None
        Ncut (eq. 1) of the best bisection found for this subgraph, whether accepted or not;
        ``None`` when no bisection was possible (a single node, or a constant eigenvector).
    """

    ncut: float | None = None

    @property
    def accepted(self) -> bool:
        """Whether this subgraph was split."""
        return not self.is_leaf


def recursive_ncut_partition(
    W: ArrayLike | sp.sparray,
    threshold: float = 1.0,
    *,
    assoc: str = "mrpt",
    laplacian: str = "normalized",
    min_size: int = 1,
    solver: str = "auto",
) -> tuple[np.ndarray, NcutNode]:
    """Recursive spectral bisection while the min-Ncut is below ``threshold`` (Section II-B).

    ``RecursivePart(G)``: bisect ``G`` with ``spectral_bisection``; if ``Ncut < threshold``
    (eq. 12-13 give ``threshold = 1``) partition both halves again, else ``G`` is a group.

    Parameters
    ----------
    W : array-like or sparse matrix of shape (n, n)
        Symmetric non-negative weights; any similarity graph (scan overlap, image similarity).
    threshold : float, default 1.0
        Accept a bisection while ``Ncut < threshold``; in ``[0, 2]``.
    assoc : {"mrpt", "paper"}
        How ``ncut`` counts the association (see ``ncut``).
    laplacian : {"normalized", "unnormalized"}
        Eigenproblem of the bisection (see ``spectral_bisection``).
    min_size : int, default 1
        Reject a bisection that leaves fewer nodes than this on either side.
    solver : {"auto", "dense", "sparse"}
        Eigensolver (see ``spectral_bisection``).

    Returns
    -------
    labels : ndarray of shape (n,), int
        Group of each node, numbered in the order of each group's first node.
    tree : NcutNode
        The bisection tree with each Ncut.
    """
    if not np.isscalar(threshold) or not 0.0 <= threshold <= 2.0:
        raise ValueError(f"threshold must be a number in [0, 2], got {threshold!r}")
    if int(min_size) != min_size or min_size < 1:
        raise ValueError(f"min_size must be a positive integer, got {min_size!r}")
    for name, value, allowed in (("assoc", assoc, ASSOC), ("laplacian", laplacian, LAPLACIAN)):
        if value not in allowed:
            raise ValueError(f"{name} must be one of {allowed}, got {value!r}")
    _check_solver(solver)
    W = check_weights(W)
    if W.shape[0] == 0:
        raise ValueError("W has no nodes")
    return partition_checked(W, threshold, assoc, laplacian, min_size, solver)


def partition_checked(
    W: np.ndarray | sp.csr_array,
    threshold: float,
    assoc: str,
    laplacian: str,
    min_size: int,
    solver: str,
) -> tuple[np.ndarray, NcutNode]:
    """Run ``recursive_ncut_partition`` on arguments already checked (a valid, non-empty ``W``).

    For callers that re-partition many small graphs, such as ``partial_fit``. Weights of huge
    magnitude are rescaled first (``RESCALE_ABOVE``).

    Parameters
    ----------
    W : ndarray or scipy.sparse.csr_array of shape (n, n)
        Checked weights (``check_weights``), at least one node.
    threshold : float
        Accept a bisection while ``Ncut < threshold``.
    assoc : {"mrpt", "paper"}
        How ``ncut`` counts the association.
    laplacian : {"normalized", "unnormalized"}
        Eigenproblem of the bisection.
    min_size : int
        Reject a bisection that leaves fewer nodes than this on either side.
    solver : {"auto", "dense", "sparse"}
        Eigensolver.

    Returns
    -------
    labels : ndarray of shape (n,), int
        Group of each node, numbered in the order of each group's first node.
    tree : NcutNode
        The bisection tree with each Ncut.
    """
    W = _rescaled(W)
    n = W.shape[0]
    if n > DENSE_INDEX_MAX_NODES:
        W = sp.csr_array(W)
    elif sp.issparse(W):
        W = W.toarray()
    root = NcutNode(np.arange(n))
    stack = [root]
    # hundreds of small eigensolves: BLAS threads only contend (see single_threaded_blas)
    with single_threaded_blas():
        while stack:  # explicit stack: no recursion limit for long trajectories
            node = stack.pop()
            idx = node.indices
            if idx.size < 2:
                continue
            if sp.issparse(W):
                sub = W[idx][:, idx]
                if idx.size <= DENSE_MAX_NODES:
                    sub = sub.toarray()
            else:
                sub = W[np.ix_(idx, idx)]
            mask, _ = _bisect(sub, laplacian, solver)
            if mask.all():  # constant eigenvector: nothing to split
                continue
            node.ncut = _ncut(sub, mask, assoc)
            if node.ncut < threshold and min(mask.sum(), (~mask).sum()) >= min_size:
                node.children = (NcutNode(idx[mask]), NcutNode(idx[~mask]))
                stack.extend(reversed(node.children))
    labels = np.empty(n, dtype=np.intp)
    leaves = sorted(root.leaves(), key=lambda leaf: leaf.indices.min())
    for k, leaf in enumerate(leaves):
        labels[leaf.indices] = k
    return labels, root
