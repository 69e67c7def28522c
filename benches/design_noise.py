#!/usr/bin/env python3
"""How much a design objective moves with the choice of axes alone (issue 56, docs/design.md
"The ranking statistic"): for one layout's sweep CSV (`max_axis_error_deg` per axis), take 100
of its axes (the first 100; with --pick, 100 drawn at random), then many random subsets of 32
of those, and print the 5th, 50th and 95th percentiles over the subsets of the worst axis
error, the mean of the worst quarter (what `design` ranks on), the median and the mean.
With --versus OTHER.csv (a sweep about the same axes, row by row), each statistic is the
ratio of the layout's to the other's on the same subset: how often 32 axes rank the two the
way all of them do. Python standard library only; seeded, so a rerun prints the same numbers.

    python3 benches/design_noise.py results/design/gen-000/full/results/g000-000.csv
    python3 benches/design_noise.py --pick results/sweep-500-axes-default.csv
    python3 benches/design_noise.py results/design/gen-003/full/results/g003-002.csv \
        --versus results/design/gen-000/full/results/g000-000.csv
"""
import argparse
import csv
import math
import random
import statistics


def tail_mean(v):
    s = sorted(v, reverse=True)
    k = math.ceil(len(s) / 4)
    return sum(s[:k]) / k


def pct(v, q):
    s = sorted(v)
    return s[min(len(s) - 1, int(q * (len(s) - 1) + 0.5))]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("csv")
    ap.add_argument("--of", type=int, default=100, help="the axes the subsets are drawn from")
    ap.add_argument("--subset", type=int, default=32)
    ap.add_argument("--draws", type=int, default=4000)
    ap.add_argument("--pick", action="store_true", help="draw the --of axes at random")
    ap.add_argument("--seed", type=int, default=56)
    ap.add_argument("--versus", help="another layout's sweep about the same axes")
    a = ap.parse_args()
    errors = read(a.csv)
    other = read(a.versus) if a.versus else [1.0] * len(errors)
    rng = random.Random(a.seed)
    rows = list(range(len(errors)))
    base = rng.sample(rows, a.of) if a.pick else rows[: a.of]
    stats = {"worst": max, "worst quarter": tail_mean, "median": statistics.median,
             "mean": statistics.fmean}
    draws = {k: [] for k in stats}
    def value(f, sub):
        return f([errors[i] for i in sub]) / f([other[i] for i in sub])

    for _ in range(a.draws):
        sub = rng.sample(base, a.subset)
        for k, f in stats.items():
            draws[k].append(value(f, sub))
    versus = f" / {a.versus}" if a.versus else ""
    print(f"{a.csv}{versus}: {a.subset} of {len(base)} axes, {a.draws} draws (seed {a.seed})")
    print("statistic       all axes    p5    p50    p95   (p95-p5)/p50" +
          ("   below 1" if a.versus else ""))
    for k, f in stats.items():
        d = draws[k]
        lo, mid, hi = pct(d, 0.05), pct(d, 0.5), pct(d, 0.95)
        below = f"   {sum(x < 1 for x in d) / len(d):6.1%}" if a.versus else ""
        print(f"{k:14} {value(f, base):8.2f} {lo:6.2f} {mid:6.2f} {hi:6.2f}   "
              f"{(hi - lo) / mid:6.1%}{below}")


def read(path):
    with open(path, newline="") as f:
        return [float(r["max_axis_error_deg"]) for r in csv.DictReader(f)]


if __name__ == "__main__":
    main()
