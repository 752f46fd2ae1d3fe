#!/usr/bin/env bash
# Configures and builds cierzo (Release, -O3) into build/, or the folder given; further
# arguments are CMake options (-D…).
#
#   scripts/build.sh [FOLDER] [-D…]           everything: the programs, the tests, the
#                                             benchmarks and the Python module
#   scripts/build.sh --render [FOLDER] [-D…]  the `cierzo` and `cierzo-tonemap` programs only,
#                                             with their libraries (scripts/render_default.sh)
#
# --render configures a new folder without the tests, benchmarks and Python module (whose
# packages `scripts/install_deps.sh --render` leaves out) and with the kernels of this
# machine's widest instruction set alone (-DCIERZO_ISAS=widest), and marks it so; the full
# build undoes exactly that in a marked folder, and so builds everything in any folder. In a
# folder configured in full, --render keeps its options and builds the two programs.
set -euo pipefail
cd "$(dirname "$0")/.."
render=false
if [ "${1:-}" = --render ]; then
    render=true
    shift
fi
build=${1:-build}
shift || true
marker=$build/.configured-by-build-render
options=()
targets=()
if $render; then
    targets=(--target cierzo cierzo-tonemap)
    if [ ! -f "$build/CMakeCache.txt" ]; then
        options=(-DCIERZO_BUILD_TESTS=OFF -DCIERZO_BUILD_BENCH=OFF -DCIERZO_PYTHON=OFF
                 -DCIERZO_ISAS=widest)
        mkdir -p "$build"
        touch "$marker"
    fi
elif [ -f "$marker" ]; then
    options=(-DCIERZO_BUILD_TESTS=ON -DCIERZO_BUILD_BENCH=ON -DCIERZO_PYTHON=ON -UCIERZO_ISAS)
fi
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release "${options[@]}" "$@" >/dev/null
$render || rm -f "$marker"
cmake --build "$build" --parallel "$(nproc)" "${targets[@]}"
