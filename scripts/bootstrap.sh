#!/usr/bin/env bash
# Set up a fresh machine: system GL libraries (Mesa EGL/OSMesa) if missing, a virtual
# environment in .venv, and the project with its dev tools. Idempotent and quick when done.
set -euo pipefail
cd "$(dirname "$0")/.."

have_lib() { ldconfig -p 2>/dev/null | grep -q "$1"; }
if ! have_lib 'libEGL.so.1' && ! have_lib 'libOSMesa'; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    echo "bootstrap: installing Mesa EGL for headless rendering" >&2
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libegl1 libgl1-mesa-dri libosmesa6 >/dev/null
  else
    echo "bootstrap: no headless OpenGL found; install Mesa EGL (Debian: sudo apt-get install libegl1 libgl1-mesa-dri)" >&2
    exit 1
  fi
fi

PY=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  "$PY" -m venv .venv
fi
stamp=.venv/.topomap-installed
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ]; then
  .venv/bin/python -m pip install -q --disable-pip-version-check -e ".[dev]"
  touch "$stamp"
fi
