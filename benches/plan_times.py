#!/usr/bin/env python3
"""Wall time of one `spherestep plan` per axis, whole process, one plan at a time.

Reads the axes of a sweep CSV (columns axis_x, axis_y, axis_z; by default the default
planner's headline sweep, results/sweep-500-axes-default.csv), plans 90 degrees about each with
the built binary on the prototype (`spherestep plan scenarios/prototype.toml --axis ...`), and
prints the median, 90th percentile and worst wall time, and the worst axis error seen.

Run from the repository root after `cargo build --release`:
    python3 benches/plan_times.py [SWEEP.csv] [--limit N] [--threads T]
"""

import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time


def summary(text):
    """The plan's JSON summary line in `text`, or None."""
    for line in text.splitlines():
        try:
            s = json.loads(line)
        except ValueError:
            continue
        if isinstance(s, dict) and "max_axis_error_deg" in s:
            return s
    return None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("sweep", nargs="?", default="results/sweep-500-axes-default.csv")
    ap.add_argument("--limit", type=int, default=0, help="only the first N axes")
    ap.add_argument("--threads", default="", help="RAYON_NUM_THREADS for each plan")
    ap.add_argument("--bin", default="target/release/spherestep")
    a = ap.parse_args()
    with open(a.sweep, newline="") as f:
        axes = [(r["axis_x"], r["axis_y"], r["axis_z"]) for r in csv.DictReader(f)]
    if a.limit:
        axes = axes[: a.limit]
    env = dict(os.environ)
    if a.threads:
        env["RAYON_NUM_THREADS"] = a.threads
    times, worst_err, failed = [], 0.0, 0
    plan_csv = os.path.join(tempfile.mkdtemp(), "plan.csv")
    for x, y, z in axes:
        t0 = time.perf_counter()
        out = subprocess.run(
            [a.bin, "plan", "scenarios/prototype.toml", "--axis", f"{x},{y},{z}",
             "--angle", "90", "--json", "--out", plan_csv],
            capture_output=True, text=True, env=env,
        )
        times.append(time.perf_counter() - t0)
        s = summary(out.stdout) or summary(out.stderr)
        if s is None:
            failed += 1
        else:
            worst_err = max(worst_err, s["max_axis_error_deg"])
            failed += 0 if s["reached"] else 1
    if not times:
        sys.exit("no axes")
    times.sort()
    n = len(times)
    print(f"{n} plans, {failed} not reached, worst axis error {worst_err:.2f} deg")
    print(
        f"wall time per plan: median {times[n // 2]:.3f} s, "
        f"90th percentile {times[int(0.9 * n)]:.3f} s, worst {times[-1]:.3f} s"
    )


if __name__ == "__main__":
    main()
