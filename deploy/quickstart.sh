#!/usr/bin/env bash
# The README's first command: install eagc, build the images offline, run the demo
# campaigns (examples/campaigns/demo_<track>.yaml) and print their leaderboards and where
# the results are. Works as root with the system Python and in a venv:
#   python3 -m venv v && . v/bin/activate && bash deploy/quickstart.sh
# With a Docker engine answering, the example agents run in the full sandbox; without one
# they run as local processes, and the demo says so. Arguments go to `eagc demo`
# (e.g. --track sanity, --output DIR).
set -euo pipefail
cd "$(dirname "$0")/.."
if ! python3 -m pip install -q -e ".[all]"; then
  echo "quickstart: installing eagc failed (pip's message above). A Python whose packages" \
       "the system manages refuses installs: use a venv (python3 -m venv v && . v/bin/activate)." >&2
  exit 1
fi
if docker info >/dev/null 2>&1 && ! command -v mmdebstrap >/dev/null 2>&1; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "installing mmdebstrap (builds the agent base image without a registry)…"
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq mmdebstrap >/dev/null
  fi
fi
exec eagc demo "$@"
