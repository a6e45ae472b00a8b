"""``experiments.servo.fix_offline``'s recordings are read as untrusted input and written
atomically."""

import numpy as np
import pytest

from experiments.servo.fix_offline import load_recording


def _write(path, **overrides):
    arrays = {
        "world": np.array("lawn"),
        "features": np.zeros((2, 5, 4), np.float32),
        "odometry": np.zeros((2, 5, 3)),
        "truth": np.zeros((2, 5, 3)),
        "start": np.zeros((2, 3)),
        "target": np.array([1, 2]),
    }
    arrays.update(overrides)
    np.savez(path, **{k: v for k, v in arrays.items() if v is not None})
    return path


def test_a_good_recording_loads(tmp_path):
    rec = load_recording(_write(tmp_path / "r.npz"))
    assert rec["world"] == "lawn" and rec["features"].shape == (2, 5, 4)


@pytest.mark.parametrize(
    "overrides, message",
    [
        ({"world": np.array("mars")}, "world must be one of"),
        ({"odometry": np.zeros((2, 5, 2))}, "expected features"),
        ({"start": np.full((2, 3), np.nan)}, "expected features"),
        ({"target": None}, "not a recording"),
        ({"world": np.array([object()], dtype=object)}, "not a recording"),
    ],
)
def test_a_bad_recording_is_refused(tmp_path, overrides, message):
    with pytest.raises(ValueError, match=message):
        load_recording(_write(tmp_path / "r.npz", **overrides))


def test_not_an_npz(tmp_path):
    path = tmp_path / "r.npz"
    path.write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="not a recording"):
        load_recording(path)


def test_consistent_fix_prefers_the_supported_place(servo_maps):
    """A lone best match is overruled by a place that the turn's other images confirm (their
    views near it, matched at the headings the map puts them at); a view matched whichever
    way the camera looks neither stands nor supports; agreement keeps the best match."""
    from experiments.servo.fix_offline import consistent_fix, neighbourhood
    from servo.route import RouteGraph

    m = servo_maps["hallway"]
    routes = RouteGraph(m)
    place = 40
    near = neighbourhood(routes, place, 4.0)
    assert near[place].tolist() == [0.0, 0.0, 0.0] and len(near) > 3
    far = int(np.flatnonzero(m.sequence != m.sequence[place])[-1])
    assert far not in near
    others = [v for v in near if v != place][:3]
    # robot heading 1.0 faces the way `place` looks; its neighbours at their map headings
    support = [(0.3, v, 1.0 + float(near[v][2])) for v in others]
    samples = [(0.1, far, 2.5), (0.25, place, 1.0), *support]
    view, heading = consistent_fix(samples, routes)  # the place or a supporting neighbour
    assert view in near and heading == pytest.approx(1.0 + near[view][2])
    # the far view matched over a wide range of headings is generic: ignored
    generic = [(0.1, far, 2.5), (0.12, far, 0.5), (0.3, place, 1.0)]
    assert consistent_fix(generic, routes) == (place, 1.0)
    # with support for the best match as well, it stands
    both = [(0.1, place, 1.0), (0.2, far, 2.5), *support]
    assert consistent_fix(both, routes) == (place, 1.0)
    with pytest.raises(ValueError, match="no localisation"):
        consistent_fix([], routes)
