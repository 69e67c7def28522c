#!/usr/bin/env python3
"""Motions to a target orientation (`spherestep plan --to`), measured from each plan's summary.

Reads the random motions of a sweep CSV (by default results/sweep-500-motions.csv: columns
start_qx..start_qw, axis_x, axis_y, axis_z, angle_deg), sends the ball from each start to the
orientation that motion's turn leads to (the rotation applied to the start, not to row 0), and
prints the median, 95th percentile and worst of the final orientation error, the path deviation
(from row 0 to the target) and the axis error over the plans, with how many are reached.

Run from the repository root after `cargo build --release`:
    python3 benches/to_motions.py [SWEEP.csv] [--every K] [--jobs J]
"""

import argparse
import csv
import json
import math
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor


def qmul(a, b):
    """The quaternion product a b, both (x, y, z, w)."""
    x1, y1, z1, w1 = a
    x2, y2, z2, w2 = b
    return (
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
    )


def target_of(row):
    """The orientation a sweep row's motion leads its start to."""
    axis = [float(row["axis_" + c]) for c in "xyz"]
    half = math.radians(float(row["angle_deg"])) / 2.0
    turn = (*(a * math.sin(half) for a in axis), math.cos(half))
    return qmul(turn, [float(row["start_q" + c]) for c in "xyzw"])


def figures(values):
    """Median / 95th percentile / worst of `values`, as text."""
    v = sorted(values)
    n = len(v)
    median = v[n // 2] if n % 2 else 0.5 * (v[n // 2 - 1] + v[n // 2])
    return f"{median:.2f} / {v[min(n - 1, int(0.95 * n))]:.2f} / {v[-1]:.2f}"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("sweep", nargs="?", default="results/sweep-500-motions.csv")
    ap.add_argument("--every", type=int, default=1, help="only every K-th motion")
    ap.add_argument("--jobs", type=int, default=2, help="plans at once")
    ap.add_argument("--bin", default="target/release/spherestep")
    ap.add_argument("--scenario", default="scenarios/prototype.toml")
    args = ap.parse_args()
    with open(args.sweep, newline="") as f:
        rows = list(csv.DictReader(f))[:: args.every]

    def plan(row):
        start = ",".join(row["start_q" + c] for c in "xyzw")
        to = ",".join(repr(v) for v in target_of(row))
        cmd = [args.bin, "plan", args.scenario, "--from", start, "--to", to, "--json"]
        out = subprocess.run(cmd + ["--out", "/dev/null"], capture_output=True, text=True)
        if out.returncode not in (0, 1):
            sys.exit(f"motion {row['case']}: {out.stderr.strip()}")
        return row["case"], json.loads(out.stdout)

    with ThreadPoolExecutor(args.jobs) as pool:
        plans = list(pool.map(plan, rows))
    print(f"{len(plans)} motions from {args.sweep}, planned --to their target")
    for key, name in [
        ("final_orientation_error_deg", "final error"),
        ("max_path_deviation_deg", "path deviation"),
        ("max_axis_error_deg", "axis error"),
        ("steps", "steps"),
    ]:
        print(f"{name} (median / p95 / worst): {figures([s[key] for _, s in plans])}")
    print(f"reached: {sum(s['reached'] for _, s in plans)} of {len(plans)}")
    case, worst = max(plans, key=lambda p: p[1]["max_path_deviation_deg"])
    print(f"worst path deviation: motion {case}, {worst['max_path_deviation_deg']:.2f} deg")


if __name__ == "__main__":
    main()
