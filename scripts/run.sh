#!/usr/bin/env bash
# README command 1: set up (first time) and run the main job end to end; writes out/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/bootstrap.sh
export MUJOCO_GL=${MUJOCO_GL:-egl}
exec .venv/bin/topomap run "$@"
