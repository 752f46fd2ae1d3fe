#!/usr/bin/env bash
# The second README command: installs what is missing, builds, checks the build's time
# budget (scripts/build_budget.py: no compile step over 60 s) and runs every test with
# ctest; then the sanitizer job runs them all again under AddressSanitizer and
# UndefinedBehaviorSanitizer (scripts/test_sanitized.sh). Says which instruction sets the
# run exercised and which it skipped, and why, and after each job every test it skipped
# with the reason (scripts/skipped_tests.sh). On x86-64 it ends with the aarch64 job
# (scripts/test_aarch64.sh): NEON, cross-built and tested under qemu-user; an aarch64 host
# has tested NEON natively by then.
set -euo pipefail
cd "$(dirname "$0")/.."
# Each job's wall time, printed at the end (where CI's time goes)
times=()
phase() { times+=("$(printf '%-28s %4d s' "$1" $((SECONDS - phase_start)))"); phase_start=$SECONDS; }
phase_start=$SECONDS
scripts/install_deps.sh
phase "install"
scripts/build.sh build
phase "native build"
# Where the build's time went, and no compile step over its budget (docs/build.md)
/usr/bin/python3 scripts/build_budget.py build
(cd build && ctest --output-on-failure --parallel "$(nproc)" --timeout 900)
scripts/skipped_tests.sh build "native tests"
phase "native tests"
scripts/test_sanitized.sh
phase "sanitizer build and tests"
native=$(scripts/isa_summary.sh build)
echo "$native"
if [ "$(uname -m)" = x86_64 ]; then
    scripts/test_aarch64.sh
    phase "aarch64 build and qemu tests"
fi
printf '%s\n' "${times[@]}"
echo "$native"  # (after the aarch64 job's line, both architectures' lines are last)
