#!/usr/bin/env python3
"""CPU time (user + system, all threads) of one `spherestep plan` per axis, for two binaries
run in turn: a comparison that a loaded machine disturbs less than wall time does.

Reads the axes of a sweep CSV (columns axis_x, axis_y, axis_z; by default the default planner's
headline sweep, results/sweep-500-axes-default.csv), plans 90 degrees about each of the first
N on the prototype with each binary in turn, and prints each binary's median and worst CPU time
and median wall time per plan.

Run from the repository root, e.g. with the binary of an older commit built in a worktree:
    python3 benches/plan_cpu_times.py --old ../old/target/release/spherestep \
        --new target/release/spherestep --limit 30
"""

import argparse
import csv
import resource
import statistics
import subprocess
import sys
import tempfile
import time


def cpu_seconds():
    """CPU time of the finished children so far, seconds."""
    u = resource.getrusage(resource.RUSAGE_CHILDREN)
    return u.ru_utime + u.ru_stime


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sweep", nargs="?", default="results/sweep-500-axes-default.csv")
    ap.add_argument("--old", required=True, help="the binary compared against")
    ap.add_argument("--new", required=True, help="the binary measured")
    ap.add_argument("--limit", type=int, default=30, help="how many axes (default 30)")
    ap.add_argument("--scenario", default="scenarios/prototype.toml")
    a = ap.parse_args()
    with open(a.sweep, newline="") as f:
        axes = [f"{r['axis_x']},{r['axis_y']},{r['axis_z']}" for r in csv.DictReader(f)]
    axes = axes[: a.limit]
    if not axes:
        sys.exit(f"{a.sweep}: no axes (columns axis_x, axis_y, axis_z)")
    bins = {"old": a.old, "new": a.new}
    cpu = {k: [] for k in bins}
    wall = {k: [] for k in bins}
    with tempfile.TemporaryDirectory() as d:
        for axis in axes:
            for k, b in bins.items():
                c0, t0 = cpu_seconds(), time.time()
                subprocess.run(
                    [b, "plan", a.scenario, "--axis", axis, "--angle", "90",
                     "--out", f"{d}/plan.csv"],
                    capture_output=True,
                )
                cpu[k].append(cpu_seconds() - c0)
                wall[k].append(time.time() - t0)
    for k in bins:
        print(f"{k}: {len(axes)} plans, CPU median {statistics.median(cpu[k]):.3f} s, "
              f"worst {max(cpu[k]):.3f} s; wall median {statistics.median(wall[k]):.3f} s")


if __name__ == "__main__":
    main()
