#!/usr/bin/env bash
# The coil-set plan tables of docs/sweeps.md: for each scenario and axis, one 90 degree
# plan (wall time of the whole process) and its replay by `simulate` in the same scenario.
# Usage: bash benches/coil_plans.sh [SCENARIO.toml ...]   (default: broad-wells and soft-wells)
# BIN=path/to/spherestep times that binary instead of building this checkout's (old against new).
# The cpu column is the plan's user + system time (all threads).
set -euo pipefail
cd "$(dirname "$0")/.."
if [ -z "${BIN:-}" ]; then
  cargo build --release --quiet
fi
bin=${BIN:-target/release/spherestep}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
scenarios=("$@")
[ ${#scenarios[@]} -gt 0 ] || scenarios=(scenarios/broad-wells.toml scenarios/soft-wells.toml)
echo "| scenario | about | steps | final angle | from the target | worst cumulative axis error | path deviation | settles | wall | cpu | replay |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for sc in "${scenarios[@]}"; do
  for axis in 0,0,1 0,1,0 1,0,0 -1,2,-1; do
    start=$(date +%s.%N)
    # a plan that ends past its tolerance exits 1: its row says how far it ended
    /usr/bin/time -f %U+%S -o "$out/cpu" \
      "$bin" plan "$sc" --axis "$axis" --angle 90 --json --out "$out/p.csv" > "$out/plan.json" || true
    end=$(date +%s.%N)
    "$bin" simulate "$out/p.csv" "$sc" --json > "$out/sim.json"
    python3 - "$sc" "$axis" "$start" "$end" "$out/plan.json" "$out/sim.json" "$out/cpu" <<'EOF'
import json, os, sys
sc, axis, start, end, plan, sim, cpu = sys.argv[1:]
cpu = sum(float(x) for x in open(cpu).read().split("\n")[-2].split("+"))
p, s = json.load(open(plan)), json.load(open(sim))
name = {"0,0,1": "Z", "0,1,0": "Y", "1,0,0": "X"}.get(axis, axis)
print(f"| {os.path.basename(sc)[:-5]} | {name} | {p['steps']} | {p['final_angle_deg']:.2f} "
      f"| {p['final_orientation_error_deg']:.2f} | **{p['max_axis_error_deg']:.2f}** "
      f"| {p['max_path_deviation_deg']:.2f} | {p['settles']} | {float(end) - float(start):.2f} s "
      f"| {cpu:.2f} s "
      f"| {s['max_deviation_deg']:.1e} |")
EOF
  done
done
