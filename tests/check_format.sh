#!/usr/bin/env bash
# Whether every C++ file of the project is formatted as .clang-format says (clang-format
# --dry-run -Werror): prints each place that is not and exits 1. Exits 77 (CTest: skipped)
# with a message where clang-format is not installed (scripts/install_deps.sh installs it).
# Usage: check_format.sh SOURCE_DIR
set -euo pipefail
cd "$1"
format=${CLANG_FORMAT:-clang-format}
if ! command -v "$format" >/dev/null; then
    echo "skipped: $format is not installed (scripts/install_deps.sh installs it)"
    exit 77
fi
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
    files=$(git ls-files '*.h' '*.cpp')
else
    files=$(find src kernels tests bench python -name '*.h' -o -name '*.cpp')
fi
# shellcheck disable=SC2086
if ! "$format" --dry-run -Werror $files; then
    echo "not formatted: apply clang-format -i to the files above (.clang-format)"
    exit 1
fi
echo "$(echo "$files" | wc -l) files formatted"
