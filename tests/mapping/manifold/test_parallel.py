"""``ManifoldClustering(n_jobs=...)``: the split search in worker processes, same result."""

import numpy as np
import pytest

import mapping.manifold.geometry as geometry_module
import mapping.manifold.split as split_module
from mapping.manifold import ManifoldClustering, branching_sequences
from mapping.manifold.geometry import GraphGeometry, knn_edges, sigma_grid


@pytest.fixture(scope="module")
def curves():
    # 8 branching curves, 640 points: on the graph path with n_components = 16 every node
    # above 64 points is a graph node, so several depths have graph and dense nodes at once
    return branching_sequences(80, 60, np.random.default_rng(3))


def _fitted(X, **kwargs):
    return ManifoldClustering(8, 20, **kwargs).fit(X)


def _same_fit(a, b):
    for name in ("labels_", "leaf_labels_", "centers_", "sigmas_", "alphas_", "omegas_"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


class _Counting:
    """Wraps joblib.Parallel where a module uses it, counting the tasks it is given."""

    def __init__(self, monkeypatch, module):
        self.tasks = 0
        real = module.Parallel

        def parallel(*args, **kwargs):
            runner = real(*args, **kwargs)

            def call(iterable):
                tasks = list(iterable)
                self.tasks += len(tasks)
                return runner(tasks)

            return call

        monkeypatch.setattr(module, "Parallel", parallel)


def test_graph_fit_in_two_processes_is_the_serial_fit(curves, monkeypatch):
    X, _ = curves
    serial = _fitted(X, kernel="sparse", n_components=16)
    nodes = _Counting(monkeypatch, split_module)
    sigmas = _Counting(monkeypatch, geometry_module)
    parallel = _fitted(X, kernel="sparse", n_components=16, n_jobs=2)
    _same_fit(serial, parallel)
    np.testing.assert_array_equal(serial.predict(X[::7]), parallel.predict(X[::7]))
    # the work did go to the workers: the root's grid of sigmas, then the nodes below it
    assert sigmas.tasks >= 16
    assert nodes.tasks >= 6


def test_dense_fit_stays_in_one_process(curves, monkeypatch):
    X, _ = curves
    nodes = _Counting(monkeypatch, split_module)
    _same_fit(_fitted(X[::2], kernel="dense", n_jobs=2), _fitted(X[::2], kernel="dense"))
    assert nodes.tasks == 0


def test_prefetched_bases_are_the_serial_ones(curves):
    X, _ = curves
    edges = knn_edges(X, 10)
    serial = GraphGeometry(X, edges, np.arange(len(X)), rank=16, dense_below=64)
    parallel = GraphGeometry(X, edges, np.arange(len(X)), rank=16, dense_below=64, n_jobs=2)
    _, sigmas = sigma_grid(*serial.sigma_bounds(), 5)
    parallel.prefetch(sigmas)
    assert set(parallel._bases) == set(sigmas)
    for sigma in sigmas:
        a, b = serial.basis(sigma), parallel.basis(sigma)
        np.testing.assert_array_equal(a.vectors, b.vectors)
        np.testing.assert_array_equal(a.values, b.values)


def test_one_job_prefetches_nothing(curves):
    X, _ = curves
    geo = GraphGeometry(X, knn_edges(X, 10), np.arange(len(X)), rank=16, dense_below=64)
    geo.prefetch(sigma_grid(*geo.sigma_bounds(), 5)[1])
    assert geo._bases == {}


def test_a_node_travels_without_the_training_points(curves):
    X, _ = curves
    geo = GraphGeometry(X, knn_edges(X, 10), np.arange(len(X)), 16, 64, n_jobs=2)
    node = geo.node(np.arange(100, 400))
    sent = node.portable()
    assert sent.X is None and sent.n_jobs == 1 and sent.size == 300
    assert sent.sigma_bounds() == node.sigma_bounds()
    # all points identical: no edge has a length, so the bounds need the points, which go
    # along (their own rows only)
    same = np.repeat(X[:1], 5, axis=0)
    flat = GraphGeometry(same, knn_edges(same, 2), np.arange(5), 16, 64).portable()
    assert flat.X.shape == (5, X.shape[1])


def test_n_jobs_must_be_an_integer_or_none(curves):
    X, _ = curves
    with pytest.raises(ValueError, match="n_jobs"):
        ManifoldClustering(8, 20, n_jobs="two").fit(X)
