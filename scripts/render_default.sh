#!/usr/bin/env bash
# The first README command: installs what rendering needs (when missing), builds the two
# programs it runs (not the tests, benchmarks or Python module: scripts/test.sh builds
# those), renders scenes/cornell.json to out/cornell.exr (float32 HDR) and out/cornell.png
# (tone-mapped), printing time and rays/s. It renders with mis, the estimator that is best
# for that scene (docs/measurements.md, "The first image"), not the report's one the scene
# names: `bash scripts/render_default.sh --estimator report` renders it as the report did.
# Further arguments go to `cierzo render`.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh --render
scripts/build.sh --render build
mkdir -p out
estimator=(--estimator mis)
for arg in "$@"; do
    case "$arg" in --estimator | --estimator=*) estimator=() ;; esac
done
if [ ${#estimator[@]} -gt 0 ]; then
    echo "rendering scenes/cornell.json with mis, the best estimator for it (the scene names" \
         "the report's: add --estimator report to render it as the report did)"
fi
build/cierzo render scenes/cornell.json "${estimator[@]}" --out out/cornell.exr \
    --stats out/cornell.json "$@"
build/cierzo-tonemap out/cornell.exr out/cornell.png --op clamp-gamma
echo "wrote out/cornell.exr, out/cornell.png and out/cornell.json (statistics)"
