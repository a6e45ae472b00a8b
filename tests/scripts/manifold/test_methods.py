"""The protocol's per-seed summary: ``bootstrap_mean``'s interval at its boundaries."""

import numpy as np
import pytest
from scipy.stats import bootstrap

from scripts.manifold.methods import bootstrap_mean

# thirty distinct error rates: enough resample means that the interval's ends move with the draw
ERRORS = np.linspace(0.0, 0.29, 30) ** 1.5


def test_the_interval_is_scipys_percentile_interval_from_the_given_generator():
    got = bootstrap_mean(ERRORS, np.random.default_rng(3), n_resamples=500)
    rng = np.random.default_rng(3)
    ref = bootstrap((ERRORS,), np.mean, n_resamples=500, method="percentile", random_state=rng)
    ref = ref.confidence_interval
    assert got == {"mean": ERRORS.mean(), "lo": ref.low, "hi": ref.high, "n": 30}
    # 4000 resamples unless told
    rng = np.random.default_rng(3)
    ref = bootstrap((ERRORS,), np.mean, n_resamples=4000, method="percentile", random_state=rng)
    got = bootstrap_mean(ERRORS, np.random.default_rng(3))
    assert (got["lo"], got["hi"]) == (ref.confidence_interval.low, ref.confidence_interval.high)
    # another seed, another interval: the draw comes from ``rng`` and nowhere else
    other = bootstrap_mean(ERRORS, np.random.default_rng(4))
    assert (other["lo"], other["hi"]) != (got["lo"], got["hi"])


def test_two_values_get_an_interval_and_equal_values_get_the_value():
    two = bootstrap_mean([0.1, 0.3], np.random.default_rng(0))
    assert two["lo"] == pytest.approx(0.1) and two["hi"] == pytest.approx(0.3)
    assert two["mean"] == pytest.approx(0.2) and two["n"] == 2
    same = bootstrap_mean([0.25, 0.25, 0.25], np.random.default_rng(0))
    assert same == {"mean": 0.25, "lo": 0.25, "hi": 0.25, "n": 3}
    # a spread of exactly 1 is a spread like any other
    assert bootstrap_mean([0.0, 1.0], np.random.default_rng(0))["lo"] == pytest.approx(0.0)


def test_booleans_count_as_zero_and_one():
    rng = np.random.default_rng
    assert bootstrap_mean([True, False, True], rng(1)) == bootstrap_mean([1.0, 0.0, 1.0], rng(1))


@pytest.mark.parametrize("values", [[], [[0.1, 0.2]], [0.1, np.inf]])
def test_empty_nested_or_infinite_values_are_refused(values):
    with pytest.raises(ValueError, match="non-empty 1-D list of finite numbers"):
        bootstrap_mean(values, np.random.default_rng(0))
