"""``common.cores.available_cores``: the process's affinity where the platform has one."""

import os

import pytest

from common import cores


def test_available_cores_is_the_affinity():
    if not hasattr(os, "sched_getaffinity"):
        pytest.skip("no CPU affinity on this platform")
    assert cores.available_cores() == len(os.sched_getaffinity(0)) >= 1


def test_without_affinity_the_cpu_count(monkeypatch):
    monkeypatch.delattr(os, "sched_getaffinity", raising=False)
    monkeypatch.setattr(os, "cpu_count", lambda: None)
    assert cores.available_cores() == 1
    monkeypatch.setattr(os, "cpu_count", lambda: 6)
    assert cores.available_cores() == 6
