#!/usr/bin/env bash
# The second README command: installs what is missing, builds, fetches the test meshes and
# runs every test with ctest; then the sanitizer job runs them all again under
# AddressSanitizer and UndefinedBehaviorSanitizer (scripts/test_sanitized.sh). Says which
# instruction sets the run exercised and which it skipped, and why. On x86-64 it ends with
# the aarch64 job (scripts/test_aarch64.sh): NEON, cross-built and tested under qemu-user;
# an aarch64 host has tested NEON natively by then.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh
scripts/build.sh build
scripts/fetch_bunny.sh scenes/data || echo "warning: could not fetch the bunny; its tests skip" >&2
export CIERZO_BUNNY_PLY="$PWD/scenes/data/bunny.ply"
(cd build && ctest --output-on-failure --parallel "$(nproc)" --timeout 900)
scripts/test_sanitized.sh
native=$(scripts/isa_summary.sh build)
echo "$native"
if [ "$(uname -m)" = x86_64 ]; then
    scripts/test_aarch64.sh
    echo "$native"  # both architectures' lines last
fi
