#!/usr/bin/env bash
# Checks that no per-ISA object (isa_*.o) shares a weak (inline) code symbol with any other
# object: the linker keeps one copy of such a symbol, and if it kept the AVX-512 one, the
# SSE path would run AVX-512 code. Arguments: every object file of the library.
set -euo pipefail
shared=0
weak() { nm -C --defined-only "$1" | awk '$2 ~ /^[WVuw]$/ { $1 = ""; $2 = ""; print }' | sort -u; }
for isa in "$@"; do
    case "$(basename "$isa")" in isa_*) ;; *) continue ;; esac
    for other in "$@"; do
        [ "$other" = "$isa" ] && continue
        # The personality-routine reference is data emitted by every C++ object, not code
        common=$(comm -12 <(weak "$isa") <(weak "$other") | grep -v 'DW.ref.__gxx_personality_v0' || true)
        if [ -n "$common" ]; then
            echo "$(basename "$isa") shares inline symbols with $(basename "$other"):"
            echo "$common" | head -5
            shared=1
        fi
    done
done
[ "$shared" = 0 ] && echo "per-ISA objects share no inline code"
exit "$shared"
