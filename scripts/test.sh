#!/usr/bin/env bash
# The second README command: installs what is missing, builds, fetches the test meshes and
# runs every test with ctest; then the sanitizer job runs them all again under
# AddressSanitizer and UndefinedBehaviorSanitizer (scripts/test_sanitized.sh). Ends by
# saying which instruction sets the run exercised and which it skipped, and why.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh
scripts/build.sh build
scripts/fetch_bunny.sh scenes/data || echo "warning: could not fetch the bunny; its tests skip" >&2
export CIERZO_BUNNY_PLY="$PWD/scenes/data/bunny.ply"
(cd build && ctest --output-on-failure --parallel "$(nproc)" --timeout 900)
scripts/test_sanitized.sh
scripts/isa_summary.sh build
