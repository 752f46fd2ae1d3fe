#!/usr/bin/env bash
# Runs every libFuzzer program built in BUILD_FOLDER/tests/fuzz for SECONDS each (default 20),
# as many at a time as the machine has cores (CIERZO_FUZZ_JOBS to choose), from a copy of its corpus in a temporary folder (the repository's corpus
# is never written), with the limits of docs/fuzzing.md (-rss_limit_mb=2048 -timeout=10) and
# its dictionary. Prints each fuzzer's executions and coverage; fails if any fuzzer finds a
# crash, a sanitizer report, a leak, a timeout or an allocation past the limit, and keeps what
# it found in BUILD_FOLDER/fuzz-smoke-artifacts/ with the fuzzer's log.
# Called by scripts/test_sanitized.sh after the sanitizer build (which builds the fuzzers);
# needs nothing beyond Debian's base system (bash, coreutils, grep, sed, find).
#
#   scripts/fuzz_smoke.sh BUILD_FOLDER [SECONDS]
set -euo pipefail

if [ $# -lt 1 ] || [ $# -gt 2 ] || [[ ! "${2:-20}" =~ ^[1-9][0-9]*$ ]]; then
    echo "usage: $0 BUILD_FOLDER [SECONDS]   (SECONDS: a whole number > 0, default 20)" >&2
    exit 2
fi
if [ ! -d "$1" ]; then
    echo "$0: no build folder $1" >&2
    exit 2
fi
build=$(cd "$1" && pwd)
seconds=${2:-20}
fuzz_dir=$(cd "$(dirname "$0")/../tests/fuzz" && pwd)
bin_dir=$build/tests/fuzz
kept=$build/fuzz-smoke-artifacts

# Each fuzzer's corpus folders (the first one's copy receives its finds) and dictionary
fuzzers=(scene ply obj image hdr_image checkpoint rank_messages)
declare -A corpora=([scene]="scene" [ply]="ply" [obj]="obj mtl" [image]="image"
                    [hdr_image]="hdr_image" [checkpoint]="checkpoint"
                    [rank_messages]="rank_messages")
declare -A dictionaries=([scene]=scene.dict [ply]=ply.dict [obj]=obj.dict)

rm -rf "$kept"  # (a previous run's)
work=$(mktemp -d "${TMPDIR:-/tmp}/cierzo-fuzz-smoke.XXXXXX")
trap 'rm -rf "$work"' EXIT
# (what the sanitizers report ends the run; leaks are looked for, as in the sanitizer job)
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

# A number of libFuzzer's final statistics (-print_final_stats=1) in a log
final_stat() { sed -n "s/^stat::$1: *\([0-9]*\).*/\1/p" "$2" | tail -1; }

# One fuzzer's run, in its own folder: its log, and its exit status in a file
fuzz_one() {
    local name=$1 run=$work/$1 corpus status=0
    mkdir -p "$run/corpus" "$run/artifacts" "$run/tmp"
    for corpus in ${corpora[$name]}; do
        cp -R "$fuzz_dir/corpus/$corpus/." "$run/corpus/"
    done
    local args=(-max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1
                -artifact_prefix="$run/artifacts/")
    if [ -n "${dictionaries[$name]:-}" ]; then
        args+=(-dict="$fuzz_dir/${dictionaries[$name]}")
    fi
    # (the fuzzers' scratch files go to the run's own folder; a fuzzer that outlives its time
    # by far, hung outside any one input, is killed)
    TMPDIR=$run/tmp timeout --kill-after=30 $((seconds + 600)) \
        "$bin_dir/fuzz_$name" "${args[@]}" "$run/corpus" >"$run/log" 2>&1 || status=$?
    echo "$status" >"$run/status"
}

# (each fuzzer is one process on one core: they run side by side, a job a core)
jobs_max=${CIERZO_FUZZ_JOBS:-$(nproc)}
for name in "${fuzzers[@]}"; do
    [ -x "$bin_dir/fuzz_$name" ] || continue
    while [ "$(jobs -rp | wc -l)" -ge "$jobs_max" ]; do wait -n || true; done
    fuzz_one "$name" &
done
wait

ran=0
failed=()
printf '%-20s %12s %10s %8s %8s  %s\n' fuzzer executions "per s" cov ft result
for name in "${fuzzers[@]}"; do
    run=$work/$name
    if [ ! -x "$bin_dir/fuzz_$name" ]; then
        printf '%-20s %12s %10s %8s %8s  %s\n' "fuzz_$name" - - - - "not built"
        continue
    fi
    # (no status: its run could not be set up, e.g. a full disk; its log may say why)
    status=$(cat "$run/status" 2>/dev/null || echo "none")
    [ -f "$run/log" ] || echo "(no log: the run could not be set up)" >"$run/log"
    mkdir -p "$run/artifacts"
    ran=$((ran + 1))
    executions=$(final_stat number_of_executed_units "$run/log")
    per_second=$(final_stat average_exec_per_sec "$run/log")
    last=$(grep -E '^#[0-9]+' "$run/log" | tail -1 || true)
    cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<<"$last")
    ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<<"$last")
    found=$(find "$run/artifacts" -type f \( -name 'crash-*' -o -name 'leak-*' -o -name 'timeout-*' \
        -o -name 'oom-*' \) | wc -l)
    result=ok
    if [ "$status" != 0 ] || [ "$found" -ne 0 ]; then
        result="FAILED (exit status $status, $found input(s) kept)"
        failed+=("fuzz_$name")
        mkdir -p "$kept/$name"
        cp -R "$run/artifacts/." "$kept/$name/"
        cp "$run/log" "$kept/$name/log"
    fi
    printf '%-20s %12s %10s %8s %8s  %s\n' "fuzz_$name" "${executions:-?}" "${per_second:-?}" \
        "${cov:-?}" "${ft:-?}" "$result"
done

for name in "${failed[@]}"; do
    log=$kept/${name#fuzz_}/log
    echo
    echo "==== $name: the end of its log ($log) ===="
    tail -n 60 "$log"
    if grep -q 'LeakSanitizer has encountered a fatal error' "$log"; then
        echo "(LeakSanitizer could not run here, e.g. without ptrace in a container: run with"
        echo " ASAN_OPTIONS=detect_leaks=0 to fuzz without the leak check)"
    fi
done
if [ "$ran" -eq 0 ]; then
    echo "$0: no fuzzer is built in $bin_dir (configure with -DCIERZO_BUILD_FUZZERS=ON and clang)" >&2
    exit 1
fi
if [ ${#failed[@]} -ne 0 ]; then
    echo
    echo "$0: ${failed[*]} found a bug; the inputs are in $kept (docs/fuzzing.md: adding a crasher)" >&2
    exit 1
fi
echo "$0: $ran fuzzers, $seconds s each, $jobs_max at a time: nothing found"
