"""contrast_fix: the observing turn's view whose match stands out against the far headings."""

import numpy as np
import pytest

from servo.camera_only.turn_global_fix import contrast_fix, contrast_scores


def _turn(n=24):
    return np.linspace(-np.pi, np.pi, n, endpoint=False)


def test_a_sharp_dip_beats_a_lower_flat_profile():
    h = _turn()
    d = np.full((len(h), 3), 1.0)
    d[5, 0] = 0.05  # view 0: a sharp dip at sample 5 (a real place)
    d[:, 1] = 0.04  # view 1: low whichever way the camera looks (a close-up of a wall)
    d[9, 2] = 0.3  # view 2: a weaker dip
    y = np.zeros_like(d)
    y[5, 0] = 0.1
    view, heading = contrast_fix(d, y, h)
    assert view == 0
    assert heading == pytest.approx(h[5] + 0.1)
    # the scores behind it: the dip's ratio to its far best, the flat profile's 1, each
    # view's heading facing its best sample
    score, facing = contrast_scores(d, y, h)
    assert score == pytest.approx([0.05, 1.0, 0.3])
    assert facing == pytest.approx([h[5] + 0.1, h[0], h[9]])


def test_nearby_samples_do_not_flatten_the_dip():
    # the neighbouring samples (within ``far``) also match a real view fairly well
    h = _turn()
    d = np.full((len(h), 2), 1.0)
    d[4:7, 0] = [0.2, 0.05, 0.2]
    d[:, 1] = 0.5
    d[12, 1] = 0.04  # better best match, but the far samples match it at 0.5
    assert contrast_fix(d, np.zeros_like(d), h, far=0.6)[0] == 0


def test_no_far_sample_falls_back_on_the_distance():
    h = np.array([0.0, 0.1])
    d = np.array([[0.5, 0.2], [0.4, 0.3]])
    assert contrast_fix(d, np.zeros_like(d), h)[0] == 1


def test_refuses_mismatched_shapes():
    with pytest.raises(ValueError):
        contrast_fix(np.ones((3, 2)), np.ones((3, 3)), np.zeros(3))
    with pytest.raises(ValueError):
        contrast_fix(np.ones((3, 2)), np.ones((3, 2)), np.zeros(2))


def test_a_fix_without_metric_support_gives_way_to_the_next_supported_view():
    """``verify`` (the turn's poses against a view, ``PoseFixes.supports``): the best-scored
    view stands where it is supported or no other of the ``candidates`` next views is; else
    the first supported one by score takes its place, with its own heading."""
    h = _turn()
    d = np.full((len(h), 4), 1.0)
    d[5, 0], d[9, 1], d[14, 2], d[20, 3] = 0.05, 0.1, 0.15, 0.2  # scores in this order
    y = np.full_like(d, 0.02)
    asked = []

    def verify(supported):
        def check(view):
            asked.append(view)
            return view in supported

        return check

    view, heading = contrast_fix(d, y, h, verify=verify({2, 3}), candidates=3)
    assert view == 2 and heading == pytest.approx(h[14] + 0.02)
    assert asked == [0, 1, 2]  # in score order, and no further than needed
    assert contrast_fix(d, y, h, verify=verify({0, 2}), candidates=3)[0] == 0
    assert contrast_fix(d, y, h, verify=verify({3}), candidates=2)[0] == 0  # beyond the next 2
    assert contrast_fix(d, y, h, verify=verify(set()), candidates=3)[0] == 0
    asked.clear()
    assert contrast_fix(d, y, h, verify=verify({3}), candidates=0)[0] == 0 and asked == []
