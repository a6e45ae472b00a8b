#!/usr/bin/env bash
# README command 2: set up (first time), lint, and run the test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/bootstrap.sh
export MUJOCO_GL=${MUJOCO_GL:-egl}
# the real-log tests skip unless TOPOMAP_RADISH names the folder of the Radish logs; a copy
# kept beside the clone is used when the variable is unset
if [[ -z "${TOPOMAP_RADISH:-}" && -d ../shared/data/radish ]]; then
    export TOPOMAP_RADISH="$PWD/../shared/data/radish"
fi
.venv/bin/ruff check .
# the layout ruff's formatter gives (.pre-commit-config.yaml runs both before a commit)
.venv/bin/ruff format --check .
# the docs and the API reference (mkdocs.yml); --strict fails on a broken link or docstring.
# Its log only on failure: --quiet would also hide the warnings from --strict's count
if ! log=$(.venv/bin/mkdocs build --strict 2>&1); then
    echo "$log" >&2
    exit 1
fi
# the suite's files spread over the cores (at most 4 processes; one file's tests stay
# together, so its module fixtures are built once)
exec .venv/bin/python -m pytest -q -n auto --maxprocesses 4 --dist loadfile "$@"
