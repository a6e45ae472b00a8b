"""Out-of-sample signal F^j(k) of eq. 13 (Section II-F/G), exact and fast.

For cluster j with points p_j (m of them), affinity W (sigma_j, zero diagonal) and degrees d,
a new point x with affinities w to p_j gives ``p_j* = p_j + {x}`` and, with x as the last
index k, ``F^j = beta (I - alpha S^j)^-1 Y^j``. Partitioning ``I - alpha S^j`` as
``[[A, -alpha s], [-alpha s^T, 1]]`` with

* ``A = I - alpha R W R``, ``R = diag(1 / sqrt(d + w))`` (x adds w to every training degree),
* ``s = R w / sqrt(sum w)`` (x's column of S^j),

the Schur complement gives the x-row of the inverse, so toward target t

    F^j(k) = beta alpha (s^T A^-1 e_t) / (1 - alpha^2 s^T A^-1 s).

A is m x m and SPD (``|eig(R W R)| <= 1`` as a principal block of S^j). The call is reduced
to a system the size of the support of w: with ``M0 = D - alpha W`` (D the training degrees),
``A = R (M0 + diag(w)) R``, so with ``z = (M0 + diag(w))^-1 w``

    F^j(k) = beta alpha z_t sqrt(d_t + w_t) / sqrt(sum w) / (1 - alpha^2 w.z / sum w),

and ``diag(w)`` has rank |S|, S the points with ``w_i > 0`` (Gaussian affinities underflow to
exactly 0 a few sigma away, so S is usually a handful of points, often none). Woodbury on the
fit-time inverse ``H = (I - alpha D^-1/2 W D^-1/2)^-1`` (its condition number is at most
``(1 + alpha) / (1 - alpha)``, unlike M0's) gives, with ``g = sqrt(w_S / d_S)``,

    (I + diag(g) H_SS diag(g)) v = sqrt(w_S),   u = g v,
    z_t sqrt(d_t + w_t) = sqrt((d_t + w_t) / d_t) H_tS . u,   w.z = sum w - sqrt(w_S) . v,

an |S| x |S| SPD system whose eigenvalues are >= 1. It is exact (no degree is approximated or
affinity dropped: entries outside S are exactly 0). A cluster with a training point of degree
0 has no H and keeps the dense solve of A. Both solvers are in
`mapping.manifold.signal_solvers`; rows and clusters of a batch are solved together, sorted by
|S| and padded with identity rows.

The distances: the cluster's centred points are kept as coordinates in an orthonormal basis of
their span (r x d, from the eigendecomposition of their Gram matrix) plus the squared norm of
what lies outside it. A query is projected once (one r x d product instead of an m x d one),
and ``|x - x_i|^2 = |c - c_i|^2 + |x_perp|^2 + |r_i|^2 - 2 x_perp . r_i`` is evaluated without
the last term (as ``|x|^2 + |x_i|^2 - 2 c . c_i``, with x centred on the cluster mean). That
term is zero when the basis holds every point (``tol = 0``: only directions with a squared
singular value below 1e-10 of the largest are dropped, so the omission is at the level of
float32 round-off); with ``tol > 0`` the weakest directions holding at most a fraction ``tol``
of the cluster's energy are dropped too (image noise, mostly), and the omitted term is bounded
by ``2 |x_perp| |r_i|`` (Cauchy-Schwarz) and near 0 for noise independent of the training
points'. ``predict`` goes through `mapping.manifold.stacked_signal.Stack`: every cluster's
arrays padded to one size and all bases stacked, so one view is centred, cast and projected
once (one GEMV) for all K clusters and solved in a few batched numpy calls, not K of each.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from common.blas import single_threaded_blas
from mapping.distances import TINY as _TINY
from mapping.manifold.kernel import affinity
from mapping.manifold.signal_solvers import dense_signal, sparse_signal
from mapping.manifold.stacked_signal import CENTRE_ELEMENTS, DerivedCache, projection_threads
from mapping.validation import check_layout, check_number

_BIG = float(np.finfo(np.float64).max)
# below 1: eq. 1's (I - alpha S) is singular at alpha = 1
_ALPHA_MAX = float(np.nextafter(1.0, 0.0))

# Directions of a cluster's span with a squared singular value below this fraction of the
# largest are numerically zero: kept in the residual norms, not in the basis (dividing by their
# singular value would amplify round-off into the basis).
_RANK_FLOOR = 1e-10


@dataclass(frozen=True)
class ClusterModel(DerivedCache):
    """What eq. 13 needs of one cluster, precomputed at fit time.

    Attributes
    ----------
    indices : ndarray of int, shape (m,)
        Training indices of the cluster's points.
    sigma : float
        sigma_j of the affinity.
    alpha : float
        alpha of eq. 13 (0.99 in the paper).
    centre : int
        Position of the centre x_lj within ``indices``.
    mean : ndarray of shape (d,), float64
        Mean of the cluster's points; data and queries are centred on it so that squared
        distances keep their precision (also in float32).
    basis : ndarray of shape (r, d)
        Orthonormal rows spanning the centred points (r <= m), in the storage dtype (float32
        halves the memory traffic that dominates a call for image-sized d). Once ``predict``
        has stacked the models it is a row block (a view, the same values) of the stack's
        matrix, not a second copy.
    coords : ndarray of shape (m, r), float64
        The centred points in that basis.
    sq_norms : ndarray of shape (m,), float64
        Squared norms of the centred points (their part outside the basis included).
    weights : ndarray of shape (m, m)
        W with zero diagonal.
    degrees : ndarray of shape (m,)
        Row sums of W.
    scale : float
        Divisor that makes F comparable across clusters in ``predict`` (see the docs).
    inverse : ndarray of shape (m, m) or None
        ``H = (I - alpha D^-1/2 W D^-1/2)^-1`` for eq. 13's Woodbury form; None when a training
        point has degree 0. Derived from the fields on construction (also of a loaded model).

    Parameters
    ----------
    indices, sigma, alpha, centre, mean, basis, coords, sq_norms, weights, degrees, scale
        The attributes above, as [`build`][mapping.manifold.cluster_model.ClusterModel.build]
        computes them from one cluster of the training data (``ManifoldClustering.fit`` builds one
        model per cluster).

    Examples
    --------
    >>> import numpy as np
    >>> from mapping.distances import squared_distances
    >>> from mapping.manifold import ClusterModel
    >>> X = np.c_[np.linspace(0.0, 1.0, 10), np.zeros(10)]
    >>> model = ClusterModel.build(X, np.arange(10), squared_distances(X), sigma=0.2, alpha=0.99,
    ...                            centre=5, dtype=np.float64)
    >>> F = model.signal(model.sq_distances(X[[4, 9]]), target=5)
    >>> bool(F[0] > F[1])  # nearer the target view along the manifold, larger F
    True

    See Also
    --------
    mapping.manifold.GraphClusterModel : The same for a cluster of a k-NN graph fit.
    mapping.manifold.ManifoldClustering : Its ``predict`` and ``signal`` read these models.
    """

    indices: np.ndarray
    sigma: float
    alpha: float
    centre: int
    mean: np.ndarray
    basis: np.ndarray
    coords: np.ndarray
    sq_norms: np.ndarray
    weights: np.ndarray
    degrees: np.ndarray
    scale: float

    def __post_init__(self) -> None:
        """Derive ``inverse`` from the fields."""
        # Not a field: saved files keep their layout, and a loaded model derives it again.
        inverse = None
        if (self.degrees > _TINY).all():
            root = 1.0 / np.sqrt(self.degrees)
            A0 = -self.alpha * (root[:, None] * self.weights * root[None, :])
            A0.flat[:: A0.shape[0] + 1] += 1.0
            # one thread always: a model loaded from a file must get H bit for bit as in fit
            with single_threaded_blas():
                inverse = np.linalg.inv(A0)
            inverse = 0.5 * (inverse + inverse.T)  # symmetric to round-off; exactly, for Woodbury
        object.__setattr__(self, "inverse", inverse)
        object.__setattr__(self, "_stacks", {})

    @classmethod
    def build(
        cls,
        X: np.ndarray,
        indices: np.ndarray,
        sq_dist: np.ndarray,
        sigma: float,
        alpha: float,
        centre: int,
        dtype: np.dtype,
        tol: float = 0.0,
    ) -> ClusterModel:
        """Precompute the cluster's state from the training data and its distance block.

        Parameters
        ----------
        X : ndarray of shape (n, d)
            Training data.
        indices : ndarray of int, shape (m,)
            Training indices of the cluster's points.
        sq_dist : ndarray of shape (m, m)
            Squared distances between the cluster's points.
        sigma : float
            sigma_j of the affinity.
        alpha : float
            alpha of eq. 13.
        centre : int
            Position of the centre within ``indices``.
        dtype : numpy.dtype
            Storage dtype of the basis.
        tol : float, default 0.0
            The largest fraction of the centred points' energy (sum of squared norms) the
            projection basis may leave out; 0 keeps every numerically non-zero direction.

        Returns
        -------
        ClusterModel
            The model, its ``scale`` eq. 4's column norm at the centre.
        """
        points = X[indices]
        mean = points.mean(axis=0, dtype=np.float64)
        basis, coords, sq_norms = _span(np.asarray(points - mean, dtype=np.float64), tol)
        W = affinity(sq_dist, sigma)
        np.fill_diagonal(W, 0.0)
        model = cls(
            indices=indices,
            sigma=sigma,
            alpha=alpha,
            centre=centre,
            mean=mean,
            basis=np.ascontiguousarray(basis, dtype=dtype),
            coords=coords,
            sq_norms=sq_norms,
            weights=W,
            degrees=W.sum(axis=1),
            scale=1.0,
        )
        return model.with_scale(_column_scale(W, alpha, centre))

    def with_scale(self, scale: float) -> ClusterModel:
        """Return the same model with the divisor ``scale`` of ``predict``'s F.

        Parameters
        ----------
        scale : float
            The new divisor.

        Returns
        -------
        ClusterModel
            A copy with ``scale`` replaced.
        """
        return replace(self, scale=scale)

    def validate(self) -> dict[str, int]:
        """Check the fields' shapes, values and agreement (a model read from a file).

        Returns
        -------
        dict of str to int
            The sizes ``m`` (points), ``d`` (features), ``r`` (basis).

        Raises
        ------
        ValueError
            If a field is malformed.
        """
        sizes = check_layout(
            self,
            {
                "indices": ("m",),
                "mean": ("d",),
                "basis": ("r", "d"),
                "coords": ("m", "r"),
                "sq_norms": ("m",),
                "weights": ("m", "m"),
                "degrees": ("m",),
            },
        )
        check_scalars(self, sizes["m"])
        if min(self.weights.min(initial=0.0), self.degrees.min(initial=0.0)) < 0:
            raise ValueError("weights and degrees must be >= 0")
        return sizes

    def sq_distances(self, X: np.ndarray) -> np.ndarray:
        """Return squared distances of rows of X to the cluster's points, clipped at 0.

        Each query is projected once onto the basis; see the module docstring for the one
        term left out.

        Parameters
        ----------
        X : ndarray of shape (k, d)
            Queries.

        Returns
        -------
        ndarray of shape (k, m)
            Squared distances.
        """
        k, d = X.shape
        q = np.empty(k)
        c = np.empty((k, self.basis.shape[0]))
        # Centre a bounded block of rows at a time: a batch of image-sized queries would
        # otherwise allocate two k x d temporaries per cluster.
        step = max(1, CENTRE_ELEMENTS // max(d, 1))
        for start in range(0, k, step):
            Xc = X[start : start + step] - self.mean
            q[start : start + step] = np.einsum("ij,ij->i", Xc, Xc)
            with projection_threads(Xc.shape[0], self.basis):  # one thread if busy: a few rows
                c[start : start + step] = np.asarray(Xc, dtype=self.basis.dtype) @ self.basis.T
        # |c - c_i|^2 + |x_perp|^2 + |r_i|^2 = |x|^2 + |x_i|^2 - 2 c . c_i (orthonormal basis)
        d2 = q[:, None] + self.sq_norms[None, :] - 2.0 * (c @ self.coords.T)
        return np.maximum(d2, 0.0)

    def signal(self, sq_dist: np.ndarray, target: int) -> np.ndarray:
        """Return F^j(k) of eq. 13 for each row of ``sq_dist`` toward local index ``target``.

        Uses ``beta = 1 - alpha``. A row whose affinity to every cluster point underflows to 0
        (x is unreachable at sigma_j) gets exactly 0.

        Parameters
        ----------
        sq_dist : ndarray of shape (k, m)
            Squared distances of the queries to the cluster's points.
        target : int
            Local index of the target point.

        Returns
        -------
        ndarray of shape (k,)
            F^j(k) of each query.
        """
        w = affinity(sq_dist, self.sigma)
        k = w.shape[0]
        # the solvers limit the BLAS threads themselves where it matters (eq13._THREADED_SOLVE)
        if self.inverse is None:
            return dense_signal(self.weights, self.degrees, self.alpha, w, target)
        return sparse_signal(
            self.inverse[None],
            self.degrees[None],
            w,
            np.zeros(k, dtype=np.intp),
            np.full(k, target),
            np.full(k, self.alpha),
        )


def _span(centred: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return an orthonormal basis (r, d) of the rows' span, coordinates (m, r), sq. norms (m,).

    From the eigendecomposition of the m x m Gram matrix (cheaper than an SVD for m << d):
    ``centred = U diag(s) B`` with ``B = diag(1/s) U^T centred``. The r kept directions are the
    strongest ones such that the energy left out is at most ``tol`` of the total.
    """
    gram = centred @ centred.T
    energy, U = np.linalg.eigh(gram)
    energy, U = np.maximum(energy[::-1], 0.0), U[:, ::-1]
    top = energy[0] if energy.size else 0.0
    left_out = np.cumsum(energy[::-1])[::-1]  # left_out[r] = energy of directions r, r+1, ...
    keep = (energy > _RANK_FLOOR * top) & (left_out > tol * left_out[0])
    r = int(np.count_nonzero(keep)) if top > 0 else 0
    s = np.sqrt(energy[:r])
    basis = (U[:, :r] / s).T @ centred
    coords = U[:, :r] * s
    return basis, coords, np.diag(gram).copy()


def check_scalars(model, m: int) -> None:
    """Check the scalar fields every cluster model has.

    sigma > 0, alpha in (0, 1), centre one of its m points, scale >= 0, all finite.

    Parameters
    ----------
    model : ClusterModel or GraphClusterModel
        The model.
    m : int
        Its number of points.

    Raises
    ------
    ValueError
        If a field is out of range.
    """
    check_number(model.sigma, "sigma", _TINY, _BIG)
    check_number(model.alpha, "alpha", _TINY, _ALPHA_MAX)
    check_number(model.centre, "centre", 0, m - 1, integer=True)
    check_number(model.scale, "scale", 0.0, _BIG)


def _column_scale(W: np.ndarray, alpha: float, centre: int) -> float:
    """Return ``|beta (I - alpha S)^-1 e_c|`` on the cluster's own points: eq. 4's column norm."""
    deg = W.sum(axis=1)
    inv_sqrt = np.zeros_like(deg)
    np.divide(1.0, np.sqrt(deg), out=inv_sqrt, where=deg > _TINY)
    S = inv_sqrt[:, None] * W * inv_sqrt[None, :]
    e = np.zeros(W.shape[0])
    e[centre] = 1.0
    col = (1.0 - alpha) * np.linalg.solve(np.eye(W.shape[0]) - alpha * S, e)
    return float(np.linalg.norm(col))
