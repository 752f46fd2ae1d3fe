#!/usr/bin/env bash
# The sanitizer job: builds the tests with AddressSanitizer and UndefinedBehaviorSanitizer
# (any report fails the test that triggered it) into build-sanitize/ and runs the suite, but for
# the statistical comparisons over every scene (below).
# Called by scripts/test.sh; run it alone after scripts/install_deps.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
# (no Python module: python cannot load an ASan-built one. The kernels of this CPU's widest
# ISA alone: every ISA's kernels are the same templates at another width, the widest reads
# and writes furthest past a batch's tail, and each per-ISA object took a third of this job's
# build; the native run has tested every ISA the CPU has by then. The others' tests skip.)
scripts/build.sh build-sanitize -DCIERZO_SANITIZE=ON -DCIERZO_BUILD_BENCH=OFF -DCIERZO_PYTHON=OFF \
    -DCIERZO_ISAS=widest
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
ctest --output-on-failure --parallel "$(nproc)" --timeout 1800 -E "$statistical"
cd ..
scripts/skipped_tests.sh build-sanitize "sanitizer tests"
