#!/usr/bin/env bash
# The closed loop with a coil-set model on mismatched coil plants (docs/closed-loop.md): two
# models (gaussian wells of 14 degrees reaching 35; cosine wells reaching 36), each driving a
# plant 20% weaker and one 20% stronger, both 15% less damped, about Y, Z, X and an oblique
# axis, 90 degrees: open loop (`run`) and closed loop (`run --closed-loop`, 1 degree of sensor
# noise). Prints one row per run: how far each ended from the goal, degrees.
# With `unseen`: two other models (gaussian 15/38, 16/40: scenarios/plants/) and their plants,
# about (1,1,1), (2,-1,3) and Y.
# Usage: bash benches/coil_closed_loop.sh [unseen]
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
bin=target/release/spherestep
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
# name shape strength width reach damping
while read -r name shape strength width reach damping; do
  {
    printf 'name = "%s"\n[rotor]\npreset = "prototype"\n[stator]\npreset = "prototype"\n' "$name"
    printf '[magnets]\nshape = "%s"\nstrength_j = %s\n' "$shape" "$strength"
    [ "$shape" = gaussian ] && printf 'width_deg = %s\n' "$width"
    printf 'max_attraction_deg = %s\ninteraction = "coils"\n' "$reach"
    printf '[body]\ninertia_kg_m2 = 0.023\ndamping_nms = %s\n[settle]\nt_max_s = 30.0\n' "$damping"
  } > "$dir/$name.toml"
done <<'LIST'
gaussian-14-35 gaussian 0.30 14 35 1.0
gaussian-weak gaussian 0.24 14 35 0.85
gaussian-strong gaussian 0.36 14 35 0.85
cosine-36 cosine 2.0 - 36 1.0
cosine-weak cosine 1.6 - 36 0.85
cosine-strong cosine 2.4 - 36 0.85
gaussian-15-38 gaussian 0.40 15 38 0.8
gaussian-15-38-weak gaussian 0.32 15 38 0.68
gaussian-15-38-strong gaussian 0.48 15 38 0.68
gaussian-16-40 gaussian 0.80 16 40 1.2
gaussian-16-40-weak gaussian 0.64 16 40 1.02
gaussian-16-40-strong gaussian 0.96 16 40 1.02
LIST
pairs=("gaussian-14-35 gaussian-weak" "gaussian-14-35 gaussian-strong" "cosine-36 cosine-weak"
  "cosine-36 cosine-strong")
axes="0,1,0 0,0,1 1,0,0 0.5,-0.6,0.6"
if [ "${1:-}" = unseen ]; then
  pairs=("gaussian-15-38 gaussian-15-38-weak" "gaussian-15-38 gaussian-15-38-strong"
    "gaussian-16-40 gaussian-16-40-weak" "gaussian-16-40 gaussian-16-40-strong")
  axes="1,1,1 2,-1,3 0,1,0"
fi
echo "| model | plant | about | open loop | closed loop (true) | closed loop (measured) | steps | replans |"
echo "|---|---|---|---|---|---|---|---|"
for pair in "${pairs[@]}"; do
  set -- $pair
  for axis in $axes; do
    # a run that ends past its tolerance exits 1: its row says how far it ended
    "$bin" run "$dir/$1.toml" --plant "$dir/$2.toml" --axis "$axis" --angle 90 --json \
      --out "$dir/open.csv" > "$dir/open.json" 2>/dev/null || true
    "$bin" run "$dir/$1.toml" --plant "$dir/$2.toml" --axis "$axis" --angle 90 --closed-loop \
      --sensor-noise-deg 1 --json --out "$dir/closed.csv" > "$dir/closed.json" 2>/dev/null || true
    python3 - "$1" "$2" "$axis" "$dir/open.json" "$dir/closed.json" <<'PY'
import json, sys
model, plant, axis, o, c = sys.argv[1:]
o, c = json.load(open(o)), json.load(open(c))
print(f"| {model} | {plant} | {axis} | {o['final_error_deg']:.2f} | {c['final_error_deg']:.2f} "
      f"| {c['final_measured_error_deg']:.2f} | {c['steps']} | {c.get('replans', '')} |")
PY
  done
done
