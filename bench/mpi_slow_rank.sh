#!/usr/bin/env bash
# A rank slowed by another job: 2 ranks x 1 thread (cornell, 960x540, 256 paths per pixel),
# each pinned to a core of its own (taskset), then the same with rank 1's core shared with a
# busy loop (rank 1 at about half speed); 3 rounds, interleaved. Prints per run the seconds,
# the units each rank rendered and its render threads' idle seconds.
#   bash bench/mpi_slow_rank.sh [BUILD_DIR]     (a machine of 2 cores or more; needs mpirun)
set -euo pipefail
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
ROOT=$(cd "$(dirname "$0")/.." && pwd)
B=${1:-$ROOT/build}/cierzo
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
A="render $ROOT/scenes/cornell.json --quiet --threads 1 --spp 256 --width 960 --height 540 --out $T/s.exr --stats $T/s.json"
for r in 1 2 3; do
  for mode in even slowed; do
    L=
    if [ $mode = slowed ]; then taskset -c 1 sh -c 'while :; do :; done' & L=$!; fi
    # shellcheck disable=SC2086
    mpirun --bind-to none -np 1 taskset -c 0 "$B" $A : -np 1 taskset -c 1 "$B" $A
    if [ -n "$L" ]; then kill "$L"; fi
    python3 -c "
import json;j=json.load(open('$T/s.json'));m=j['mpi']
print('$mode', round(j['seconds'],3), [r['units'] for r in m['per_rank']], [round(r['idle_seconds'],3) for r in m['per_rank']])"
  done
done
