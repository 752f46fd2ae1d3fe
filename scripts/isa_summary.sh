#!/usr/bin/env bash
# Prints which wavefront ISAs a test run exercised and which it skipped, and why, from
# `cierzo isas` of the build given (the ISA tests skip exactly where the CPU lacks the ISA):
#   ISAs tested (x86_64): avx2 sse4.2 · skipped: avx512 (this CPU lacks avx512f, …)
# Usage: scripts/isa_summary.sh BUILD_DIR [LABEL [EMULATOR ARGS…]]
set -euo pipefail
build=$1
label=${2:-$(uname -m)}
shift $(($# < 2 ? $# : 2))
tested=() skipped=()
while IFS=$'\t' read -r name lanes runs why; do
    if [ "$runs" = no ]; then skipped+=("$name ($why)"); else tested+=("$name"); fi
done < <("$@" "$build/cierzo" isas)
line="ISAs tested ($label): ${tested[*]:-none}"
if [ ${#skipped[@]} -gt 0 ]; then
    line+=" · skipped: ${skipped[0]}"
    for s in "${skipped[@]:1}"; do line+="; $s"; done
fi
echo "$line"
