"""``predict``'s one projection of a query for all clusters (eq. 13's distances, stacked) against
each cluster's own ``sq_distances`` and ``signal``.

Tolerances: float64 storage agrees to round-off (1e-9 of ``|x - mean_j|^2 + |x_i - mean_j|^2``,
the size of the terms of the distance); float32 storage to 2e-5 of it (the projection is a
float32 product either way, and the per-cluster path is itself ~1e-6 off a float64
projection), and F^j (eq. 13) to 1e-3 of the largest F of the cluster.
"""

import copy
import json
import pickle

import numpy as np
import pytest

from mapping import persistence
from mapping.manifold import SYNTHETIC_SETS, ManifoldClustering, branching_sequences
from mapping.manifold import stacked_signal as _manifold_stack
from mapping.manifold.graph_cluster_model import GraphClusterModel
from mapping.manifold.stacked_signal import Projection, Stack

RTOL = {np.dtype(np.float64): 1e-9, np.dtype(np.float32): 2e-5}


@pytest.fixture(scope="module")
def curves():
    """8 branching curves in 3000 dimensions, each ~20x its own spread from the training mean:
    centring on the training mean instead of the cluster's is the hard case for round-off."""
    X, _ = branching_sequences(20, 3000, np.random.default_rng(3))
    return X[::2], X[1::2]


def _fit(train, dtype, tol, **kw):
    return ManifoldClustering(8, 8, store_dtype=dtype, projection_tol=tol, **kw).fit(train)


def _check_against_each_cluster(models, queries):
    """Stacked distances and F against every cluster's own, within the module's tolerances."""
    stack = Stack.of(models)
    d2 = stack.sq_distances(queries)
    scores, nearest = stack.scores(queries, normalize=False)
    rtol = RTOL[models[0].basis.dtype]
    for j, m in enumerate(models):
        own = m.sq_distances(queries)
        size = own.shape[1]
        scale = ((queries - m.mean) ** 2).sum(axis=1)[:, None] + m.sq_norms[None, :]
        assert (np.abs(d2[j, :, :size] - own) <= rtol * scale).all()
        assert np.isinf(d2[j, :, size:]).all()  # padding: at infinity
        f = m.signal(own, m.centre)
        atol = 1e-3 * max(np.abs(f).max(), 1e-300) if rtol > 1e-6 else 1e-9 * np.abs(f).max()
        np.testing.assert_allclose(scores[:, j], f, rtol=0, atol=atol)
        want = own.min(axis=1) / (2 * m.sigma**2)
        slack = 1e-3 * want + rtol * scale.max(axis=1) / (2 * m.sigma**2)
        # a cluster a query cannot reach (Stack.reachable) is not projected on: infinite,
        # and only where its nearest point is far beyond exp's underflow (F exactly 0)
        pruned = np.isinf(nearest[:, j])
        assert (want[pruned] > 745).all() and (f[pruned] == 0).all()
        assert (np.abs(nearest[~pruned, j] - want[~pruned]) <= slack[~pruned]).all()
    lost = ~(scores.max(axis=1) > 0)  # every F 0: the fallback reads every cluster's nearest
    assert np.isfinite(nearest[lost]).all()


@pytest.mark.parametrize("dtype", ["float32", "float64"])
@pytest.mark.parametrize("tol", [0.0, 1e-4])
def test_stack_matches_each_cluster_alone(curves, dtype, tol):
    train, test = curves
    model = _fit(train, dtype, tol)
    queries = np.vstack([test, train[::7], test[:3] + 50.0])  # near, on, and far from all
    _check_against_each_cluster(model._models, queries)
    scores, _ = Stack.of(model._models).scores(queries, normalize=False)
    assert (scores > 0).sum() > queries.shape[0] and (scores == 0).any()


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_one_cluster(dtype):
    X, _ = SYNTHETIC_SETS["parallel_lines"](n_per_line=30)
    model = ManifoldClustering(1, 10, store_dtype=dtype).fit(X)
    assert len(model._models) == 1
    _check_against_each_cluster(model._models, X[::4] + 1e-3)
    np.testing.assert_array_equal(model.predict(X), 0)


def test_blocks_of_rows_match_each_cluster_alone(curves, monkeypatch):
    # blocks of 2 rows, and one block above _FEW_ROWS (default BLAS threads): both within
    # the tolerance of the per-cluster path
    train, test = curves
    model = _fit(train, "float32", 1e-4)
    _check_against_each_cluster(model._models, test)
    monkeypatch.setattr(_manifold_stack, "CENTRE_ELEMENTS", 2 * train.shape[1])
    _check_against_each_cluster(model._models, test)


def test_predict_is_the_argmax_of_the_signals(curves):
    train, test = curves
    for normalize in ("column", "none"):
        model = _fit(train, "float32", 0.0, normalize=normalize)
        signals = np.stack([model.signal(test, j) for j in range(8)], axis=1)
        if normalize == "column":
            signals /= np.array([m.scale for m in model._models])[None, :]
        found = signals.max(axis=1) > 0
        assert found.sum() >= 0.9 * len(test)
        predicted = model.predict(test)
        np.testing.assert_array_equal(predicted[found], signals[found].argmax(axis=1))
        np.testing.assert_array_equal(model.predict_proba(test).argmax(axis=1), predicted)


def test_bases_become_views_of_the_stack_with_the_same_values(curves):
    train, _ = curves
    model = _fit(train, "float32", 0.0)
    before = [m.basis.copy() for m in model._models]
    projection = Stack.of(model._models).projection
    assert projection.matrix.shape == (sum(b.shape[0] for b in before), train.shape[1])
    assert projection.shifts.shape == (8, train.shape[1])
    for m, b in zip(model._models, before, strict=True):
        assert m.basis.base is projection.matrix  # no second copy of the bases
        np.testing.assert_array_equal(m.basis, b)
    assert Stack.of(model._models) is Stack.of(list(model._models))  # built once


def test_loaded_model_rebuilds_the_stack_and_predicts_alike(curves):
    train, test = curves
    model = _fit(train, "float32", 1e-4)
    expected = model.predict_proba(test)  # builds the stack before saving
    meta, arrays = persistence.dump(model, "m")
    assert not any("matrix" in key or "shift" in key for key in arrays)  # derived, not saved
    loaded = persistence.load(ManifoldClustering, json.loads(json.dumps(meta)), arrays, "m")
    assert loaded._models[0]._stacks == {}
    np.testing.assert_array_equal(loaded.predict_proba(test), expected)
    _check_against_each_cluster(loaded._models, test)


def test_pickles_and_copies_leave_the_stack_out(curves):
    train, test = curves
    model = _fit(train, "float32", 0.0)
    expected = model.predict_proba(test)
    assert model._models[0]._stacks  # built
    for other in (pickle.loads(pickle.dumps(model)), copy.deepcopy(model)):
        assert all(m._stacks == {} for m in other._models)
        np.testing.assert_array_equal(other.predict_proba(test), expected)
        assert other._models[0]._stacks and model._models[0].basis.base is not None


def test_graph_fit_projects_once_for_all_clusters():
    X, _ = SYNTHETIC_SETS["parallel_lines"](n_per_line=40)
    X = X + 3.0  # off the origin: centring matters
    model = ManifoldClustering(3, 10, kernel="sparse", n_components=8).fit(X)
    models = model._models
    assert all(isinstance(m, GraphClusterModel) for m in models)
    own = [m.sq_distances(X[::3] + 1e-3) for m in models]  # before the projection exists
    projection = Projection.of(models, "points")
    cross, q = projection(X[::3] + 1e-3)
    for j, m in enumerate(models):
        assert m.points.base is projection.matrix
        a, b = projection.starts[j], projection.starts[j + 1]
        d2 = np.maximum(q[:, j : j + 1] + m.sq_norms[None, :] - 2.0 * cross[:, a:b], 0.0)
        scale = q[:, j : j + 1] + m.sq_norms[None, :]
        assert (np.abs(d2 - own[j]) <= 2e-5 * scale).all()
    np.testing.assert_array_equal(model.predict(X), model.labels_)


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_pruned_clusters_are_beyond_underflow(curves, dtype):
    """``sq_distances(prune=True)`` skips exactly the clusters whose every affinity underflows:
    infinite there, the unpruned distances elsewhere; on the curves most (query, cluster)
    pairs are pruned, so the bound is doing work."""
    train, test = curves
    stack = Stack.of(_fit(train, dtype, 1e-4)._models)
    queries = np.vstack([test, test[:3] + 50.0])
    full = stack.sq_distances(queries)
    pruned = stack.sq_distances(queries, prune=True)
    skipped = np.isinf(pruned).all(axis=2)  # (K, k)
    assert 0.5 < skipped.mean() < 1.0
    exponent = full.min(axis=2) * -stack.gain[:, None]
    assert (exponent[skipped] > 745).all()
    kept = ~skipped
    np.testing.assert_allclose(pruned[kept], full[kept], rtol=1e-12)
    assert (stack.reachable(stack.projection(queries)[1]).T == kept).all()


@pytest.mark.parametrize("load, one_thread", [(0.2, False), (1.4, False), (1.5, True), (6.0, True)])
def test_a_view_is_projected_on_one_blas_thread_only_on_a_busy_machine(
    monkeypatch, load, one_thread
):
    """Two cores: a second BLAS thread streams twice the bytes where a core is free, and
    spins where none is (load average >= cores - 0.5)."""
    from contextlib import nullcontext

    from common import blas as _validation

    monkeypatch.setattr(_validation, "available_cores", lambda: 2)
    monkeypatch.setattr(_validation.os, "getloadavg", lambda: (load, load, load))
    big = np.zeros((8, 1 << 18), np.float32)
    ctx = _manifold_stack.projection_threads(1, big)
    assert isinstance(ctx, nullcontext) != one_thread
    assert isinstance(_manifold_stack.projection_threads(100, big), nullcontext)  # many rows


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_float32_queries_are_projected_in_float64(curves, dtype):
    """A float32 query gives the distances of the same values in float64 (its norm and its
    products with the shifts are accumulated in float64, not float32)."""
    train, test = curves
    stack = Stack.of(_fit(train, dtype, 0.0)._models)
    q32 = test.astype(np.float32)
    np.testing.assert_allclose(
        stack.sq_distances(q32), stack.sq_distances(q32.astype(np.float64)), rtol=1e-9
    )


WANTED = [[1, 0, 1, 1, 0, 0, 1, 0], [0] * 8, [1] * 8, [0, 0, 0, 0, 0, 0, 0, 1]]


@pytest.mark.parametrize("wanted", WANTED)
def test_only_the_wanted_models_rows_are_projected(curves, wanted):
    """``needed``: the wanted models' columns equal the full projection's (consecutive wanted
    models in one product), the others are left NaN."""
    train, test = curves
    projection = Stack.of(_fit(train, "float64", 0.0)._models).projection
    wanted = np.array(wanted, dtype=bool)
    full, q_full = projection(test)
    part, q = projection(test, lambda q: np.broadcast_to(wanted, q.shape))
    np.testing.assert_array_equal(q, q_full)
    columns = wanted[projection.owner]
    np.testing.assert_array_equal(part[:, columns], full[:, columns])
    assert np.isnan(part[:, ~columns]).all()
    runs = projection._runs(wanted)
    assert sum(b - a for a, b in runs) == columns.sum()
    assert all(columns[a:b].all() for a, b in runs)


def test_one_blas_thread_inside_and_each_librarys_own_count_back_after():
    """``single_threaded_blas`` (the libraries' own setters, not ``ThreadpoolController.limit``):
    one thread inside, nested too, and every library's previous count after, also on error."""
    from threadpoolctl import threadpool_info, threadpool_limits

    from common.blas import single_threaded_blas

    def counts():
        return [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]

    with threadpool_limits(limits=2, user_api="blas"):
        before = counts()
        assert before  # numpy's OpenBLAS at least
        with single_threaded_blas():
            assert set(counts()) == {1}
            with single_threaded_blas():
                assert set(counts()) == {1}
            assert set(counts()) == {1}
        assert counts() == before
        with pytest.raises(RuntimeError), single_threaded_blas():
            raise RuntimeError
        assert counts() == before
