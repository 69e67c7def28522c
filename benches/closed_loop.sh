#!/usr/bin/env bash
# The closed-loop tables of docs/closed-loop.md: plans made in one scenario's physics, played on a
# plant, open loop and closed loop with a simulated orientation sensor of three noise levels.
# Usage: bash benches/closed_loop.sh MODEL.toml PLANT.toml [NOISE_DEG ...]
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
bin=target/release/spherestep
model=${1:?usage: closed_loop.sh MODEL.toml PLANT.toml [NOISE_DEG ...]}
plant=${2:?usage: closed_loop.sh MODEL.toml PLANT.toml [NOISE_DEG ...]}
shift 2
noises=("$@")
[ ${#noises[@]} -gt 0 ] || noises=(0.5 1 2)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "| about | loop | sensor noise | steps (planned) | replans | final error to the goal | worst axis error | steered by |"
echo "|---|---|---|---|---|---|---|---|"
for axis in 0,0,1 0,1,0 1,0,0; do
  runs=("open 0")
  for n in "${noises[@]}"; do runs+=("closed $n"); done
  for r in "${runs[@]}"; do
    set -- $r
    flags=()
    # the sensor's options are the closed loop's (open loop measures without noise)
    [ "$1" = closed ] && flags+=(--closed-loop --sensor-noise-deg "$2")
    "$bin" run "$model" --plant "$plant" --axis "$axis" --angle 90 "${flags[@]}" \
      --json --out "$out/run.csv" > "$out/run.json" || true
    python3 - "$axis" "$out/run.json" <<'PY'
import json, sys
axis, path = sys.argv[1:]
s = json.load(open(path))
name = {"0,0,1": "Z", "0,1,0": "Y", "1,0,0": "X"}[axis]
fit = s.get("fitted")
by = f"fitted after step {s['fitted_after_step']}: {fit}" if fit else "the model"
print(f"| {name} | {s['mode']} | {s['sensor_noise_deg']:g} deg | {s['steps']} ({s['planned_steps']}) "
      f"| {s['replans']} | **{s['final_error_deg']:.2f}** | {s['max_axis_error_deg']:.2f} | {by} |")
PY
  done
done
