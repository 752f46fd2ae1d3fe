#!/usr/bin/env bash
# The sanitizer job: builds the tests with clang's AddressSanitizer and
# UndefinedBehaviorSanitizer (any report fails the test that triggered it; clang's
# -fsanitize=undefined checks array bounds, which GCC's does not where an index runs past a
# row of a two-dimensional array) into build-sanitize/ and runs the suite, but for the
# statistical comparisons over every scene (below); then the fuzzers, built in the same
# folder, each run briefly from their corpora (scripts/fuzz_smoke.sh).
# Called by scripts/test.sh; run it alone after scripts/install_deps.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
# (no Python module: python cannot load an ASan-built one. The kernels of this CPU's widest
# ISA alone: every ISA's kernels are the same templates at another width, the widest reads
# and writes furthest past a batch's tail, and each per-ISA object took a third of this job's
# build; the native run has tested every ISA the CPU has by then. The others' tests skip.)
# (a folder configured with another compiler is configured afresh)
if [ -f build-sanitize/CMakeCache.txt ] &&
    ! grep -q '^CMAKE_CXX_COMPILER:[A-Z]*=.*clang++' build-sanitize/CMakeCache.txt; then
    rm -rf build-sanitize
fi
CC=clang CXX=clang++ scripts/build.sh build-sanitize -DCIERZO_SANITIZE=ON -DCIERZO_BUILD_BENCH=OFF \
    -DCIERZO_PYTHON=OFF -DCIERZO_ISAS=widest -DCIERZO_BUILD_FUZZERS=ON
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
# The lighter settings of the statistical and whole-render tests that the qemu suite uses
# (fewer paths, smaller images): here the sanitizers look for memory errors and undefined
# behaviour, the native run has already checked the statistics at full strength
export CIERZO_TEST_EMULATED=1
# The statistical comparisons over every scene are left to the native run (the script says
# why)
source scripts/statistical_tests.sh
cd build-sanitize
# The per-ISA symbol check is the shipped build's (the native run makes it for every ISA):
# clang at -O1 keeps small standard functions (std::clamp, std::bad_alloc's constructor)
# out of line in every object, and the sanitizers add type information to each
ctest --output-on-failure --parallel "$(nproc)" --timeout 1800 \
    -E "$statistical|^isa_objects_share_no_inline_code\$"
cd ..
scripts/skipped_tests.sh build-sanitize "sanitizer tests"
# Each fuzzer for a short while from its corpus (docs/fuzzing.md)
scripts/fuzz_smoke.sh build-sanitize "${CIERZO_FUZZ_SECONDS:-20}"
