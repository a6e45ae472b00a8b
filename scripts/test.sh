#!/usr/bin/env bash
# README command 2: set up (first time), lint, and run the test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/bootstrap.sh
export MUJOCO_GL=${MUJOCO_GL:-egl}
.venv/bin/ruff check .
exec .venv/bin/python -m pytest -q "$@"
