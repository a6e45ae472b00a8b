"""The Wilson interval of the servo's success rates (``servo.task.stats``), against SciPy's."""

import numpy as np
import pytest
from scipy.stats import binomtest

from servo.task.stats import WILSON_Z, wilson_interval


@pytest.mark.parametrize("n", [1, 2, 3, 6, 10, 20, 100])
def test_matches_scipy_for_every_count(n):
    for k in range(n + 1):
        ci = binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
        np.testing.assert_allclose(wilson_interval(k, n), (ci.low, ci.high), atol=1e-12)


def test_other_levels_and_the_default_z():
    assert WILSON_Z == pytest.approx(1.959963984540054, abs=1e-15)
    for z, level in ((1.0, 0.682689492137086), (2.5758293035489004, 0.99)):
        ci = binomtest(7, 12).proportion_ci(confidence_level=level, method="wilson")
        np.testing.assert_allclose(wilson_interval(7, 12, z), (ci.low, ci.high), atol=1e-9)


def test_bounds_and_symmetry():
    # the closed form overshoots [0, 1] by a rounding error at some counts (11/11 and 0/21
    # first): the interval is clamped to [0, 1]
    for n in range(1, 101):
        assert wilson_interval(0, n)[0] < 1e-15 and wilson_interval(n, n)[1] > 1.0 - 1e-15
        for k in range(n + 1):
            lo, hi = wilson_interval(k, n)
            assert 0.0 <= lo <= k / n + 1e-15 and k / n - 1e-15 <= hi <= 1.0 and lo < hi
    lo, hi = wilson_interval(3, 10)
    lo2, hi2 = wilson_interval(7, 10)
    assert lo == pytest.approx(1 - hi2, abs=1e-15) and hi == pytest.approx(1 - lo2, abs=1e-15)
    assert all(isinstance(v, float) for v in wilson_interval(1, 3))


@pytest.mark.parametrize("successes, n", [(3, 2), (-1, 5), (0, 0), (1, -1)])
def test_impossible_counts_are_refused(successes, n):
    expected = rf"need 0 <= successes <= n and n >= 1, got {successes}/{n}"
    with pytest.raises(ValueError, match=expected):
        wilson_interval(successes, n)
