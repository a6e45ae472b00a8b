"""The harness through the public commands built on the readers: the servo map builder
(``load_or_build``, as ``topomap servo-eval`` calls it, and the command itself) on damaged
datasets and on datasets that cannot give a map (61 beams, 20 frames), which it refuses
naming the dataset and what to collect; never a numpy or clustering error, never a
traceback."""

import contextlib
import io
import shutil

import numpy as np
import pytest

from scripts.cli import main
from servo.maps import load_or_build
from servo.maps.needs import MIN_BEAMS
from servo.maps.types import MapError
from sim.dataset import DatasetError
from tests.fuzz.harness import Judge, case_count
from tests.fuzz.test_fuzz_dataset import KINDS, _case, clean  # noqa: F401  (the fixture)
from tests.sim.dataset_fixtures import sequence_arrays, write_dataset


def _never(_map) -> None:
    raise AssertionError("a map was built from a dataset of 5 frames and 4 beams")


def test_the_builder_refuses_every_damaged_dataset_naming_it(clean, tmp_path):  # noqa: F811
    rng = np.random.default_rng(600)
    maps = tmp_path / "maps"
    judge = Judge(
        lambda p: load_or_build("lawn", p, maps, progress=False), (DatasetError, MapError), _never
    )
    n = case_count(30)
    for case in range(n):
        kind = KINDS[case % len(KINDS)]
        path = tmp_path / f"case{case}"
        _case(clean, path, kind, rng, case)
        judge(kind, path)
        if case % 3 == 0:  # and through the command
            _through_servo_eval(judge, kind, path, maps)
        shutil.rmtree(path)
    judge.assert_clean(least=n)
    assert not maps.exists() or not any(maps.iterdir()), "a map file was left"


def _through_servo_eval(judge, kind, path, maps):
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            status = main(
                [
                    "servo-eval",
                    "--world",
                    "lawn",
                    "--episodes",
                    "1",
                    "--data",
                    str(path),
                    "--maps",
                    str(maps),
                ]
            )
    except Exception as exc:  # what the fuzz looks for
        judge.escapes.append(f"{kind}: topomap servo-eval raised {type(exc).__name__}: {exc}")
        return
    text = err.getvalue()
    if status != 2 or "Traceback" in text or str(path) not in text:
        judge.escapes.append(f"{kind}: topomap servo-eval exit {status}: {text[:300]}")


def _short(tmp_path, beams: int, frames: int):
    arrays = sequence_arrays(frames)
    arrays["scans"] = np.full((frames, beams), 2.0, np.float32)
    arrays["angles"] = np.linspace(-np.pi / 2, np.pi / 2, beams).astype(np.float32)
    return write_dataset(tmp_path / "data", arrays)


@pytest.mark.parametrize(
    ("beams", "frames", "says"),
    [
        (
            61,
            100,
            r"the scans have 61 beams; .* needs at least 141 beams per scan: record with "
            r"a laser of more beams",
        ),
        (
            MIN_BEAMS,
            20,
            r"give 10 stored views .* needs 32: collect at least 64 frames per "
            r"sequence \(topomap collect --frames\)",
        ),
    ],
)
def test_servo_eval_on_a_dataset_that_cannot_give_a_map_says_what_to_collect(
    tmp_path, beams, frames, says
):
    import re

    data = _short(tmp_path, beams, frames)
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        status = main(
            [
                "servo-eval",
                "--world",
                "lawn",
                "--episodes",
                "1",
                "--data",
                str(data),
                "--maps",
                str(tmp_path / "maps"),
            ]
        )
    assert status == 2 and "Traceback" not in err.getvalue()
    assert re.search(says, err.getvalue()), err.getvalue()
    assert f"topomap servo-eval: {data}: " in err.getvalue()
    with pytest.raises(DatasetError, match=says):
        load_or_build("lawn", data, tmp_path / "maps", progress=False)
