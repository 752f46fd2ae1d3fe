#!/usr/bin/env bash
# Configures and builds cierzo (Release, -O3) into build/, or the folder given; further
# arguments are CMake options (-D…), which override the ones set here.
#
#   scripts/build.sh [FOLDER] [-D…]           everything: the programs, the tests, the
#                                             benchmarks and the Python module
#   scripts/build.sh --render [FOLDER] [-D…]  the `cierzo` and `cierzo-tonemap` programs and
#                                             their libraries only (scripts/render_default.sh)
#
# A folder configured first with --render leaves the tests, benchmarks and Python module out
# (their packages are not needed then); the full build switches them back on, so it builds
# everything in any folder. --render in a folder configured in full keeps its options and
# builds just the two programs.
set -euo pipefail
cd "$(dirname "$0")/.."
render=false
if [ "${1:-}" = --render ]; then
    render=true
    shift
fi
build=${1:-build}
shift || true
if ! $render; then
    options=(-DCIERZO_BUILD_TESTS=ON -DCIERZO_BUILD_BENCH=ON -DCIERZO_PYTHON=ON)
    targets=()
elif [ -f "$build/CMakeCache.txt" ]; then
    options=()
    targets=(--target cierzo cierzo-tonemap)
else
    options=(-DCIERZO_BUILD_TESTS=OFF -DCIERZO_BUILD_BENCH=OFF -DCIERZO_PYTHON=OFF)
    targets=(--target cierzo cierzo-tonemap)
fi
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release "${options[@]}" "$@" >/dev/null
cmake --build "$build" --parallel "$(nproc)" "${targets[@]}"
