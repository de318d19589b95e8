#!/usr/bin/env bash
# Builds eagc/worker:latest with no network inside the build.
#
# 1. eagc/worker-base:bookworm: eagc/base:bookworm's recipe (a Debian bookworm root made by
#    mmdebstrap from the Debian mirror, `docker import`-ed) plus Mesa's EGL, so that the sim
#    host renders headless (MUJOCO_GL=egl). Skip it with BASE=eagc/base:bookworm for a
#    worker that never renders.
# 2. The wheels of eagc[orchestrator] are downloaded on the host (PyPI) into the build
#    context and installed with --no-index: `docker build --network none`.
#
# Usage: deploy/worker/build.sh [TAG]      (then: docker save TAG | gzip > eagc-worker.tar.gz)
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
tag=${1:-eagc/worker:latest}
base=${BASE:-eagc/worker-base:bookworm}
mirror=${MIRROR:-http://deb.debian.org/debian}
ctx=$(mktemp -d)
trap 'rm -rf "$ctx"' EXIT

# Mesa's EGL and the GL dispatch libraries PyOpenGL loads (mujoco's EGL backend needs both).
packages=python3,python3-pip,ca-certificates,libegl1,libegl-mesa0,libgl1-mesa-dri,libgl1,libopengl0
have=$(docker image inspect --format '{{index .Config.Labels "eagc.build-hash"}}' "$base" 2>/dev/null || true)
if [ "$base" = eagc/worker-base:bookworm ] && [ "$have" != "$packages" ]; then
  command -v mmdebstrap >/dev/null || { echo "apt-get install -y mmdebstrap" >&2; exit 1; }
  echo "building $base with mmdebstrap…"
  mmdebstrap --variant=minbase --include="$packages" bookworm "$ctx/rootfs.tar" "$mirror"
  docker import --change 'CMD ["python3"]' --change 'ENV MUJOCO_GL=egl' \
    --change "LABEL eagc.build-hash=$packages" "$ctx/rootfs.tar" "$base" >/dev/null
  rm -f "$ctx/rootfs.tar"
elif ! docker image inspect "$base" >/dev/null 2>&1; then
  echo "$base is missing: eagc images build" >&2
  exit 1
fi

mkdir -p "$ctx/wheels"
python3 -m pip wheel -q --no-deps --no-build-isolation -w "$ctx/wheels" "$repo"
wheel=$(ls "$ctx"/wheels/eagc-*.whl)
# The base is Debian bookworm's Python 3.11 on this machine's architecture.
python3 -m pip download -q --only-binary=:all: --python-version 3.11 -d "$ctx/wheels" \
  "eagc[orchestrator] @ file://$wheel"
cp "$repo/deploy/worker/Dockerfile" "$ctx/Dockerfile"
docker build --network none --build-arg "BASE=$base" -t "$tag" "$ctx"
echo "built $tag ($(docker image inspect --format '{{.Id}}' "$tag"))"
