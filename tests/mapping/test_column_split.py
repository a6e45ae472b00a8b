"""``map_columns``: chunks shared between the caller and a pool thread, in order, errors raised."""

import itertools
import threading
import time

import numpy as np
import pytest

from mapping import _column_split
from mapping._column_split import map_columns


@pytest.fixture(autouse=True)
def idle(monkeypatch):
    """The tests run on a shared machine: split as if it were idle."""
    monkeypatch.setattr(_column_split, "busy", lambda: False)


@pytest.mark.parametrize("cores", [1, 2, 4])
@pytest.mark.parametrize("chunks", [1, 3, 8])
def test_chunks_cover_the_columns_in_order(monkeypatch, cores, chunks):
    monkeypatch.setattr(_column_split, "cores", lambda: cores)
    x = np.arange(1000.0)
    parts = map_columns(lambda cols: (cols.start, cols.stop, x[cols].sum()), 1000, chunks)
    assert len(parts) == chunks
    assert parts[0][0] == 0 and parts[-1][1] == 1000
    assert all(a[1] == b[0] for a, b in itertools.pairwise(parts))
    assert sum(p[2] for p in parts) == x.sum()


def test_more_chunks_than_columns():
    assert len(map_columns(lambda cols: cols, 3, 8)) == 3


def test_pool_threads_take_chunks(monkeypatch):
    """With two cores both threads take chunks: whichever takes chunk 0 holds it until the
    other has run one."""
    monkeypatch.setattr(_column_split, "cores", lambda: 2)
    caller = threading.get_ident()
    started = threading.Event()
    ran = set()

    def fn(cols):
        ran.add(threading.get_ident())
        if cols.start == 0:
            started.wait(timeout=5.0)
        else:
            started.set()
        return cols.start

    assert map_columns(fn, 100, 4) == [0, 25, 50, 75]
    assert caller in ran and len(ran) == 2


def test_a_stalled_pool_thread_does_not_hold_up_the_call(monkeypatch):
    """A chunk claimed by a pool thread that stalls (descheduled) is computed by the caller."""
    monkeypatch.setattr(_column_split, "cores", lambda: 2)
    caller = threading.get_ident()
    release = threading.Event()

    def fn(cols):
        if threading.get_ident() != caller:
            release.wait(timeout=10.0)
        else:
            time.sleep(0.01)  # the caller's own chunks take 10 ms: its patience is 5 ms
        return cols.start

    start = time.perf_counter()
    assert map_columns(fn, 100, 4) == [0, 25, 50, 75]
    assert time.perf_counter() - start < 2.0
    release.set()


def test_a_busy_machine_runs_on_the_caller(monkeypatch):
    monkeypatch.setattr(_column_split, "cores", lambda: 2)
    monkeypatch.setattr(_column_split, "busy", lambda: True)
    caller = threading.get_ident()
    assert set(map_columns(lambda cols: threading.get_ident(), 100, 4)) == {caller}


def test_an_error_in_a_chunk_is_raised(monkeypatch):
    monkeypatch.setattr(_column_split, "cores", lambda: 2)

    def fn(cols):
        if cols.start > 0:
            raise ZeroDivisionError("chunk")
        return 0

    with pytest.raises(ZeroDivisionError, match="chunk"):
        map_columns(fn, 100, 4)


@pytest.mark.parametrize("d, chunks", [(0, 1), (10, 0)])
def test_bad_sizes(d, chunks):
    with pytest.raises(ValueError, match="d and chunks"):
        map_columns(lambda cols: cols, d, chunks)


def test_a_forked_child_builds_its_own_pool(monkeypatch):
    """The pool's threads do not survive a fork: the child must not reuse the parent's."""
    import multiprocessing

    monkeypatch.setattr(_column_split, "cores", lambda: 2)
    map_columns(lambda cols: cols, 10, 2)  # the parent's pool exists
    ctx = multiprocessing.get_context("fork")
    with ctx.Pool(1) as pool:
        assert pool.apply(_column_split_in_child) == 2


def _column_split_in_child() -> int:
    _column_split.cores = lambda: 2
    assert _column_split._POOL is None
    return len(map_columns(lambda cols: cols, 10, 2))
