"""The paper's four synthetic sets: shapes, labels, sampling intervals, determinism."""

import matplotlib
import numpy as np
import pytest

from mapping.manifold import (
    SYNTHETIC_SETS,
    branching_sequences,
    converging_paths,
    lines_variable_spacing,
    make_all,
    parallel_lines,
    plot_sets,
    spirals_3d,
)

EXPECTED = {
    "parallel_lines": (2, [100, 100, 100]),
    "lines_variable_spacing": (2, [201, 81, 41]),
    "converging_paths": (2, [200, 80, 40]),
    "spirals_3d": (3, [201, 101, 51]),
}
Q = 20  # the paper's minimum cluster size for these sets


def _step_lengths(X, y):
    """Distances between consecutive points of each curve."""
    return [np.linalg.norm(np.diff(X[y == k], axis=0), axis=1) for k in range(3)]


@pytest.mark.parametrize("name", list(SYNTHETIC_SETS))
def test_shapes_labels_and_cluster_sizes(name):
    X, y = SYNTHETIC_SETS[name]()
    dim, sizes = EXPECTED[name]
    assert X.dtype == np.float64 and X.shape == (sum(sizes), dim)
    np.testing.assert_array_equal(np.bincount(y), sizes)
    # Points come cluster by cluster, as on the x axis of the paper's Figures 2-5.
    assert np.all(np.diff(y) >= 0)
    assert min(sizes) >= 2 * Q
    assert np.isfinite(X).all()


@pytest.mark.parametrize("name", list(SYNTHETIC_SETS))
def test_deterministic_without_noise_and_seeded_with_noise(name):
    make = SYNTHETIC_SETS[name]
    np.testing.assert_array_equal(make()[0], make()[0])
    a = make(noise=0.01, rng=np.random.default_rng(3))[0]
    b = make(noise=0.01, rng=np.random.default_rng(3))[0]
    c = make(noise=0.01, rng=np.random.default_rng(4))[0]
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    assert 0.005 < np.std(a - make()[0]) < 0.02


def test_parallel_lines_equally_spaced_and_parallel():
    X, y = parallel_lines(n_per_line=50, gap=0.3, length=1.0)
    for k, steps in enumerate(_step_lengths(X, y)):
        np.testing.assert_allclose(steps, 1.0 / 49)
        np.testing.assert_allclose(X[y == k, 1], 0.3 * k)


@pytest.mark.parametrize("make", [lines_variable_spacing, converging_paths, spirals_3d])
def test_each_curve_sampled_at_its_own_interval(make):
    spacings = (0.02, 0.03, 0.05)
    X, y = make(spacings=spacings)
    for steps, h in zip(_step_lengths(X, y), spacings, strict=True):
        # Chords of a curved path are a little shorter than the arc-length interval.
        assert np.all(steps <= h + 1e-12)
        assert np.all(steps > 0.99 * h)


def test_converging_paths_meet_at_the_origin_without_shared_points():
    X, y = converging_paths()
    first = np.array([X[y == k][0] for k in range(3)])
    np.testing.assert_allclose(np.linalg.norm(first, axis=1), (0.01, 0.025, 0.05), rtol=1e-3)
    assert len(np.unique(X, axis=0)) == len(X)
    # Left turns to +y, right to -y, the straight path stays on the x axis.
    assert X[y == 0, 1].min() >= 0 and X[y == 2, 1].max() <= 0
    np.testing.assert_array_equal(X[y == 1, 1], 0.0)


def test_spirals_are_interleaved_helices_on_one_axis():
    X, y = spirals_3d()
    np.testing.assert_allclose(np.hypot(X[:, 0], X[:, 1]), 0.15)
    starts = np.arctan2(*np.array([X[y == k][0, 1::-1] for k in range(3)]).T)
    np.testing.assert_allclose(np.mod(np.diff(starts), 2 * np.pi), 2 * np.pi / 3)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"spacings": (0.01, 0.02)}, "spacings must be three"),
        ({"spacings": (0.01, -0.02, 0.03)}, "spacings must be three"),
        ({"spacings": (0.01, 0.02, 3.0)}, "must not exceed length"),
        ({"noise": 0.1}, "needs rng"),
        ({"noise": -1.0}, "noise must be"),
    ],
)
def test_bad_parameters_raise(kwargs, match):
    with pytest.raises(ValueError, match=match):
        lines_variable_spacing(**kwargs)


def test_other_bad_parameters_raise():
    with pytest.raises(ValueError, match="n_per_line"):
        parallel_lines(n_per_line=1)
    with pytest.raises(ValueError, match="turn"):
        converging_paths(turn=0.0)
    with pytest.raises(ValueError, match="radius"):
        spirals_3d(radius=0.0)


def test_plot_sets_writes_a_png(tmp_path):
    matplotlib.use("Agg")
    path = tmp_path / "sets.png"
    fig = plot_sets(path, sets=make_all())
    assert len(fig.axes) == 4
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: parallel_lines(length=np.nan), "length must be a positive finite number"),
        (lambda: parallel_lines(length=np.inf), "length must be"),
        (lambda: parallel_lines(length=-1.0), "length must be"),
        (lambda: parallel_lines(length=0), "length must be"),
        (lambda: parallel_lines(gap="0.3"), "gap must be"),
        (lambda: parallel_lines(noise="0.1"), "noise must be a non-negative number"),
        (lambda: parallel_lines(noise=np.nan), "noise must be"),
        (lambda: lines_variable_spacing(spacings=0.01), "spacings must be three positive"),
        (lambda: lines_variable_spacing(spacings="abc"), "spacings must be three positive"),
        (lambda: lines_variable_spacing(spacings=(1e-300, 0.01, 0.01)), "spacings: length / "),
        (lambda: converging_paths(turn="1"), "turn must be"),
        (lambda: spirals_3d(pitch=np.nan), "pitch must be"),
    ],
)
def test_unusable_parameters_are_refused_by_name(make, match):
    """NaN, inf or non-positive lengths gave NaN data silently; a scalar or a string spacing,
    a string noise or a vanishing spacing failed inside numpy."""
    with pytest.raises(ValueError, match=match):
        make()


@pytest.mark.parametrize("noise", [np.nan, -1.0, np.inf, "0.02"])
def test_branching_sequences_refuse_bad_noise(noise):
    with pytest.raises(ValueError, match="noise must be a non-negative number"):
        branching_sequences(5, 2, np.random.default_rng(0), noise=noise)
