#!/usr/bin/env python3
"""Design layouts on axes the design run never saw (issue 56, docs/design.md "What 12 coils
cost"): each layout scenario given (a design run's `layouts/NAME.toml` or
`gen-GGG/full/scenarios/NAME.toml`) gets the 500-axis Fibonacci lattice of
`scenarios/sweep-500-axes-default.toml` as its sweep, and `spherestep batch --shard 0/EVERY`
plans every EVERY-th of those axes (case k with k mod EVERY = 0: 100 axes by default). The
prototype's plans about the same axes are the same cases of the committed
`results/sweep-500-axes-default.csv` (the same planner and settings, so the same bytes), so
nothing is planned for it. Prints one row per layout: worst, mean of the worst quarter,
median and mean axis error, median / worst steps, worst final error, reached, and axis by axis
against the prototype: the share of axes where the layout's error is lower and the mean
difference. Python standard library and the `spherestep` binary.

    python3 benches/design_unseen.py --out /tmp/unseen DIR/layouts/g001-003.toml ...
"""
import argparse
import csv
import math
import os
import statistics
import subprocess
import tomllib

SWEEP = '\n[sweep]\naxes = "sphere"\naxis_count = 500\nschemes = ["search"]\n'
PROTO = "results/sweep-500-axes-default.csv"


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def tail_mean(v):
    s = sorted(v, reverse=True)
    k = math.ceil(len(s) / 4)
    return sum(s[:k]) / k


def stats(rs, proto=None):
    e = [float(r["max_axis_error_deg"]) for r in rs]
    steps = [int(r["steps"]) for r in rs]
    fin = [float(r["final_orientation_error_deg"]) for r in rs]
    out = [max(e), tail_mean(e), statistics.median(e), statistics.fmean(e),
           f"{statistics.median(steps):g} / {max(steps)}", max(fin),
           f"{sum(r['reached'] == 'true' for r in rs)}/{len(rs)}"]
    if proto:
        p = [float(r["max_axis_error_deg"]) for r in proto]
        out.append(f"{sum(a < b for a, b in zip(e, p)) / len(e):.0%}, "
                   f"{statistics.fmean(a - b for a, b in zip(e, p)):+.2f}")
    return out


def relocated(line, name, here):
    """A scenario line as its copy elsewhere needs it: the new name, files made absolute."""
    if line.startswith("name = "):
        return f'name = "unseen-{name}"'
    for key in ("file = ", "table = "):
        if line.startswith(key) and not line[len(key) + 1:].startswith("/"):
            rel = line[len(key):].strip().strip('"')
            return f'{key}"{os.path.normpath(os.path.join(here, rel))}"'
    return line


def coil_count(scenario):
    """The coils of a scenario: its `[stator] points`, or the rows of its `[stator] file`."""
    with open(scenario, "rb") as t:
        stator = tomllib.load(t).get("stator", {})
    if "points" in stator:
        return len(stator["points"])
    if "file" in stator:
        with open(stator["file"], newline="") as f:
            return sum(1 for r in csv.reader(f) if r and r[0][:1] in "-.0123456789")
    return "?"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("layouts", nargs="+")
    ap.add_argument("--out", required=True)
    ap.add_argument("--every", type=int, default=5)
    ap.add_argument("--bin", default="target/release/spherestep")
    ap.add_argument("--jobs", default="1")
    a = ap.parse_args()
    sc = os.path.join(a.out, "scenarios")
    os.makedirs(sc, exist_ok=True)
    files = []
    for path in a.layouts:
        name = os.path.splitext(os.path.basename(path))[0]
        text = open(path).read()
        text = text[: text.index("\n[sweep]")] if "\n[sweep]" in text else text
        here = os.path.dirname(os.path.abspath(path))
        lines = [relocated(l, name, here) for l in text.splitlines()]
        f = os.path.join(sc, f"unseen-{name}.toml")
        with open(f, "w") as o:
            o.write("\n".join(lines) + "\n" + SWEEP)
        files.append((name, f))
    res = os.path.join(a.out, "results")
    subprocess.run([a.bin, "batch", *[f for _, f in files], "--out", res, "--resume",
                    "--jobs", a.jobs, "--shard", f"0/{a.every}"], check=True)
    proto = [r for r in rows(PROTO) if int(r["case"]) % a.every == 0]
    head = ["layout", "coils", "worst", "worst quarter", "median", "mean", "median / worst steps",
            "worst final", "reached", "lower than the prototype's, mean difference"]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))

    def line(name, coils, s):
        cells = [f"{x:.2f}" if isinstance(x, float) else str(x) for x in s]
        print(f"| {name} | {coils} | " + " | ".join(cells) + " |")

    line("the prototype", 16, stats(proto) + ["-"])
    for name, f in files:
        rs = rows(os.path.join(res, f"unseen-{name}.shard-0-of-{a.every}.csv"))
        assert [r["case"] for r in rs] == [r["case"] for r in proto], name
        coils = coil_count(f)
        line(name, coils, stats(rs, proto))


if __name__ == "__main__":
    main()
