#!/usr/bin/env bash
# README command 2: set up (first time), lint, and run the test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/bootstrap.sh
export MUJOCO_GL=${MUJOCO_GL:-egl}
.venv/bin/ruff check .
# the docs and the API reference (mkdocs.yml); --strict fails on a broken link or docstring
.venv/bin/mkdocs build --strict --quiet
# the suite's files spread over the cores (at most 4 processes; one file's tests stay
# together, so its module fixtures are built once)
exec .venv/bin/python -m pytest -q -n auto --maxprocesses 4 --dist loadfile "$@"
