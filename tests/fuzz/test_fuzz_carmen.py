"""The harness on the Carmen reader: damaged plain and gzip logs, special numbers and huge
counts in any field, scans of another beam count, lone carriage returns, compression bombs and
special files give a CarmenError naming the file (and the right line) or a valid log."""

import gzip

import numpy as np
import pytest

from sim.readers import carmen
from sim.readers.carmen import CarmenError, read_carmen
from tests.fuzz.harness import (
    SPECIAL_FILES,
    Judge,
    case_count,
    flipped,
    gz_bomb,
    special_file,
    truncated,
)
from tests.sim.readers.fuzzing import SPECIAL_TEXT
from tests.sim.readers.test_fuzz import _assert_valid, _flaser_log, _robotlaser_log

CAP = 1 << 20  # MAX_LOG_BYTES during the fuzz: a bomb is refused after 1 MiB, not 1 GiB
KINDS = (
    "truncated",
    "flipped",
    "field",
    "huge count",
    "beams",
    "lone CR",
    "gz",
    "bomb",
    "special file",
    "max range",
)


def _damaged(text: str, kind: str, rng: np.random.Generator) -> tuple[bytes, int | None]:
    """``(file bytes, the line the error must name or None)``."""
    lines = text.rstrip("\n").split("\n")
    scans = [k for k, line in enumerate(lines) if line.startswith(("FLASER", "ROBOTLASER1"))]
    k = scans[int(rng.integers(len(scans)))]
    fields = lines[k].split(" ")
    count_at = 1 if fields[0] == "FLASER" else 8
    if kind == "truncated":
        return truncated(text.encode(), rng), None
    if kind == "flipped":
        return flipped(text.encode(), rng, int(rng.integers(1, 4))), None
    if kind == "field":
        fields[int(rng.integers(1, len(fields)))] = str(rng.choice(SPECIAL_TEXT))
    elif kind == "huge count":
        fields[count_at] = str(rng.choice(["9" * 30, str(10**400), "-5", "0", "1e3", "2"]))
    elif kind == "beams":  # one scan of another beam count: refused at its line
        n = int(fields[count_at])
        fields[count_at] = str(n + 1)
        fields.insert(count_at + 1, "1.0")
        lines[k] = " ".join(fields)
        return ("\n".join(lines) + "\n").encode(), (k + 1 if k != scans[0] else None)
    elif kind == "lone CR":  # a \r before a broken line leaves its number as the file's
        lines[int(rng.integers(0, k + 1))] += "\r"
        fields[1] = "x"
        lines[k] = " ".join(fields)
        return ("\n".join(lines) + "\n").encode(), k + 1
    elif kind == "max range":
        value = rng.choice(["1e300", "-1", "0", "nan", "inf", "1e5"])
        lines.insert(0, f"PARAM robot_front_laser_max {value} host 0")
        if fields[0] == "ROBOTLASER1":
            fields[5] = str(value)
    lines[k] = " ".join(fields) if kind != "max range" or fields[0] != "FLASER" else lines[k]
    data = ("\n".join(lines) + "\n").encode("ascii", "replace")
    return (gzip.compress(data, mtime=0) if rng.random() < 0.3 else data), None


@pytest.mark.parametrize("seed", [0, 1])
def test_every_kind_of_damage_gives_a_carmen_error_or_a_valid_log(tmp_path, monkeypatch, seed):
    monkeypatch.setattr(carmen, "MAX_LOG_BYTES", CAP)
    rng = np.random.default_rng(100 + seed)
    judge = Judge(read_carmen, CarmenError, _assert_valid, seconds=5.0)
    n = case_count(70) // 2
    for case in range(n):
        text = (_flaser_log if case % 2 else _robotlaser_log)(rng)
        kind = KINDS[case % len(KINDS)]
        path = tmp_path / f"case{case}.log"
        line = None
        if kind == "gz":
            path.write_bytes(flipped(gzip.compress(text.encode(), mtime=0), rng))
        elif kind == "bomb":
            path.write_bytes(gz_bomb(int(rng.integers(CAP + 1, 4 * CAP))))
        elif kind == "special file":
            special_file(path, SPECIAL_FILES[case // len(KINDS) % len(SPECIAL_FILES)])
        else:
            data, line = _damaged(text, kind, rng)
            path.write_bytes(data)
        outcome = judge(kind, path)
        if line is not None and outcome == "read":
            judge.escapes.append(f"{kind}: line {line} is damaged, but the log was read")
        elif line is not None and outcome == "refused":
            try:
                read_carmen(path)
            except CarmenError as err:
                if f"line {line}:" not in str(err):
                    judge.escapes.append(f"{kind}: expected line {line} named: {err}"[:300])
    judge.assert_clean(least=n)
    assert judge.outcomes["bomb", "refused"] > 0 and judge.outcomes["special file", "refused"] > 0
