#!/usr/bin/env bash
# The README's test command: install eagc with its test extras and run every test.
# Docker tests build their images offline (first run: about two minutes) and need an engine:
# in CI (CI=true) a missing engine fails them; on a laptop without one they skip, saying so.
set -euo pipefail
cd "$(dirname "$0")/.."
export MUJOCO_GL="${MUJOCO_GL:-egl}"  # headless rendering (no display here)
python3 -m pip install -q -e ".[all,dev]"
exec python3 -m pytest -q -p no:cacheprovider "$@"
