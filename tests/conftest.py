"""Shared fixtures. Importing ``sim`` first chooses the headless GL backend."""

import pytest

import sim  # noqa: F401  (must come before anything imports mujoco)
from scenes import build_world


@pytest.fixture(scope="session")
def worlds():
    return {name: build_world(name) for name in ("hallway", "lawn")}
