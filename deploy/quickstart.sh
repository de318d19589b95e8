#!/usr/bin/env bash
# The README's first command: install eagc and run the main job on an embedded default.
# With a Docker engine answering, the example agent runs in the full sandbox (images are
# built offline first); without one it runs as a local process, and says so.
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -m pip install -q -e ".[all]"
if docker info >/dev/null 2>&1 && ! command -v mmdebstrap >/dev/null 2>&1; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "installing mmdebstrap (builds the agent base image without a registry)…"
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq mmdebstrap >/dev/null
  fi
fi
exec eagc demo "$@"
