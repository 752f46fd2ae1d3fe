#!/usr/bin/env bash
# Lists the tests the last ctest run in BUILD skipped, each with the reason it gave (the
# line after GoogleTest's "Skipped"), so that a skip is seen, not only counted. A skip for
# want of a download or a missing file is a fault: every file the tests read is in the
# repository or generated (scenes/meshes/README.md).
# Usage: scripts/skipped_tests.sh BUILD [LABEL]
set -euo pipefail
build=$1
label=${2:-$1}
log=$build/Testing/Temporary/LastTest.log
[ -f "$log" ] || { echo "skipped_tests.sh: no $log (ctest has not run there)" >&2; exit 1; }
awk -v label="$label" '
    /^[0-9]+\/[0-9]+ Test: / { name = $3 }
    /: Skipped$/ { getline reason; skips[++n] = name ": " reason }
    END {
        if (n == 0) { printf "%s: no test skipped\n", label; exit }
        printf "%s: %d test(s) skipped:\n", label, n
        for (i = 1; i <= n; ++i) printf "  %s\n", skips[i]
    }' "$log"
