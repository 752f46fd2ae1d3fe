#!/usr/bin/env bash
# The first README command: installs what rendering needs (when missing), builds the two
# programs it runs (not the tests, benchmarks or Python module: scripts/test.sh builds
# those), renders scenes/cornell.json to out/cornell.exr (float32 HDR) and out/cornell.png
# (tone-mapped), printing time and rays/s.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh --render
scripts/build.sh --render build
mkdir -p out
build/cierzo render scenes/cornell.json --out out/cornell.exr --stats out/cornell.json "$@"
build/cierzo-tonemap out/cornell.exr out/cornell.png --op clamp-gamma
echo "wrote out/cornell.exr, out/cornell.png and out/cornell.json (statistics)"
