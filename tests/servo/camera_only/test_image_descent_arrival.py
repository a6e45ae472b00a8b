"""``DescentArrival``: the search across by the image distance where F is not seen."""

import numpy as np
import pytest

from servo.camera_only.config import SignalServoConfig
from servo.camera_only.image_descent_arrival import DescentArrival, parabola_vertex
from servo.camera_only.peak_arrival import PeakArrival
from tests.servo.camera_only.arrival_sim import drive_arrival


def _arrive(arrival, true_view_xy, steps=1500, wall=None):
    return drive_arrival(arrival, true_view_xy, steps, wall)


@pytest.mark.parametrize("beside", [[4.3, 1.8], [3.8, -1.2], [4.0, 2.6]])
def test_a_search_across_finds_a_view_far_beside_the_line_of_sight(beside):
    """1.2-2.6 m beside: F's sweep never sees the view; the search across by the distance
    brings the robot onto the view's sight, where F's peak settles it."""
    config = SignalServoConfig(arrive_descent=True)
    closest, _ = _arrive(PeakArrival(config), np.array(beside))
    assert closest > 1.0
    arrival = DescentArrival(config)
    closest, final = _arrive(arrival, np.array(beside))
    assert closest < 0.2 and final < 0.3 and arrival.done
    assert 1 <= arrival.searches <= config.descent_rounds


def test_on_the_line_of_sight_it_arrives_as_the_f_peak_does():
    """F seen on the line: no search; the same commands as ``PeakArrival``."""
    config = SignalServoConfig(arrive_descent=True)
    for along in (3.6, 4.5):
        arrival = DescentArrival(config)
        _, final = _arrive(arrival, np.array([along, 0.0]))
        _, final_peak = _arrive(PeakArrival(config), np.array([along, 0.0]))
        assert final < 0.3 and arrival.done and arrival.searches == 0
        assert final == pytest.approx(final_peak)


def test_a_point_across_it_cannot_reach_turns_the_search_the_other_way():
    """A wall 0.5 m left of the believed line, the view 1.5 m right: the search's first
    point (1 m left) lies past the wall; the search reads it as no match and goes right."""
    arrival = DescentArrival(SignalServoConfig(arrive_descent=True))
    closest, final = _arrive(arrival, np.array([4.2, -1.5]), wall=0.5)
    assert closest < 0.2 and final < 0.5  # within the success radius


def test_parabola_vertex():
    assert parabola_vertex(1.0, 0.0, 1.0, 1.0) == pytest.approx(0.0)
    # least between the centre and the left reading
    assert 0.0 < parabola_vertex(0.2, 0.1, 0.6, 1.0) < 0.5
    assert -0.5 < parabola_vertex(0.6, 0.1, 0.2, 1.0) < 0.0
    # not curving up: the lower side, 1.5 steps
    assert parabola_vertex(0.0, 0.5, 1.0, 1.0) == pytest.approx(1.5)
    assert parabola_vertex(1.0, 0.5, 0.0, 2.0) == pytest.approx(-3.0)
