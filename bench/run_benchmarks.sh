#!/usr/bin/env bash
# Runs every benchmark of bench/ and writes the results as Google Benchmark JSON and one
# CSV table (name, rays/s, rays/s per thread, lane utilisation) that plots can read.
# Usage: bench/run_benchmarks.sh [OUT_DIR] [--quick]   (default OUT_DIR: out/bench)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/bench}
min_time=1
[ "${2:-}" = "--quick" ] && min_time=0.2
mkdir -p "$out"
scripts/build.sh build >/dev/null
run() {  # program, output name
    "$1" --benchmark_min_time="$min_time" --benchmark_out="$out/$2.json" \
         --benchmark_out_format=json
}
run build/bench/bench_render render
# A kernel program per ISA this CPU runs (the others refuse, saying what the CPU lacks)
while IFS=$'\t' read -r name lanes runs why; do
    if [ "$runs" = no ]; then echo "skipping bench_kernels for $name: $why" >&2; continue; fi
    isa=${name//./}
    run "build/bench/bench_kernels_$isa" "kernels_$isa"
done < <(build/cierzo isas)
/usr/bin/python3 - "$out" <<'PY'
import csv, json, pathlib, sys
out = pathlib.Path(sys.argv[1])
rows = []
for f in sorted(out.glob("*.json")):
    for b in json.loads(f.read_text())["benchmarks"]:
        rows.append({"program": f.stem, "name": b["name"],
                     "rays_per_s": b.get("rays_per_s", ""),
                     "rays_per_s_per_thread": b.get("rays_per_s_per_thread", b.get("rays_per_s", "")),
                     "shade_lane_util": b.get("shade_lane_util", ""),
                     "isect_lane_util": b.get("isect_lane_util", ""),
                     "real_time": b["real_time"], "time_unit": b["time_unit"]})
with open(out / "results.csv", "w", newline="") as fh:
    w = csv.DictWriter(fh, fieldnames=list(rows[0].keys()))
    w.writeheader()
    w.writerows(rows)
print(f"wrote {out}/results.csv ({len(rows)} rows) and the JSON beside it")
PY
