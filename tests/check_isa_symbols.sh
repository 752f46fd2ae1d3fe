#!/usr/bin/env bash
# Checks that no per-ISA object (isa_*.o, or any object of an isa_* object library) shares a
# weak (inline) code symbol with any other object: the linker keeps one copy of such a
# symbol, and if it kept the AVX-512 one, the SSE path would run AVX-512 code. Per-ISA
# objects of one target (one CMake <target>.dir, built with one ISA's flags: the parts of
# isa_wavefront_<isa>) may share with each other. Arguments:
# object files, or CMake lists of them (separated by ';'); the ones after --per-isa are
# per-ISA whatever their names. $NM names the nm for the objects' target (CMake passes its
# CMAKE_NM, e.g. aarch64-linux-gnu-nm in a cross build); plain nm otherwise.
set -euo pipefail
nm=${NM:-nm}
objects=()
per_isa=()
targets=()
marked=0
# The CMake target folder (<target>.dir) an object was built in, or the object itself
target_of() {
    local dir
    dir=$(dirname "$1")
    while [ "$dir" != / ] && [ "$dir" != . ] && [[ "$dir" != *.dir ]]; do dir=$(dirname "$dir"); done
    if [[ "$dir" == *.dir ]]; then echo "$dir"; else echo "$1"; fi
}
for arg in "$@"; do
    if [ "$arg" = --per-isa ]; then marked=1; continue; fi
    IFS=';' read -ra parts <<<"$arg"
    for o in "${parts[@]}"; do
        case "$o" in *.gch | *.pch) continue ;; esac  # (a precompiled header holds no code)
        objects+=("$o")
        targets+=("$(target_of "$o")")
        case "$o" in */isa_*) per_isa+=(1) ;; *) per_isa+=("$marked") ;; esac
    done
done
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# The weak symbols of each object, once; the personality-routine reference is data emitted
# by every C++ object, not code
isas=0
for i in "${!objects[@]}"; do
    o=${objects[$i]}
    [ -f "$o" ] || { echo "no such object file: $o"; exit 1; }
    "$nm" -C --defined-only "$o" >"$work/nm" || { echo "$nm failed on $o"; exit 1; }
    awk '$2 ~ /^[WVuw]$/ { $1 = ""; $2 = ""; print }' "$work/nm" |
        grep -v 'DW.ref.__gxx_personality_v0' | sort -u >"$work/$i" || true
    isas=$((isas + per_isa[i]))
done
# A check over no per-ISA object would pass whatever the build did
[ "$isas" -gt 0 ] || { echo "no per-ISA object among the ${#objects[@]} objects given"; exit 1; }
shared=0
for i in "${!objects[@]}"; do
    [ "${per_isa[$i]}" = 1 ] || continue
    for j in "${!objects[@]}"; do
        [ "$i" = "$j" ] && continue
        [ "${per_isa[$j]}" = 1 ] && [ "${targets[$i]}" = "${targets[$j]}" ] && continue
        common=$(comm -12 "$work/$i" "$work/$j")
        if [ -n "$common" ]; then
            echo "${objects[$i]} shares inline symbols with ${objects[$j]}:"
            echo "$common" | head -5
            shared=1
        fi
    done
done
[ "$shared" = 0 ] && echo "$isas per-ISA objects share no inline code with any other target's (${#objects[@]} objects checked)"
exit "$shared"
