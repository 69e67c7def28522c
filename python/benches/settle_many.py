"""settle_many from Python against `spherestep settle --sets` on the same sets, whole-process
timing: each side is a fresh process that reads the same sets file, loads the same scenario and
settles every set in parallel (the command line writes its CSV to a pipe read and thrown away;
Python reads the numpy columns it returns). The two are checked to give the same numbers.

    python python/benches/settle_many.py [--sets 10000] [--repeats 7] [--seed 1]
        [--scenario scenarios/prototype.toml] [--bin target/release/spherestep]

The sets: 2 to 4 distinct coils, each paired with a distinct magnet within the well's cut-off
(30 degrees in the prototype) of it at the start (the identity), drawn at random (seed): sets
that hold the ball and settle as a planner's do, not sets that are left alone at once. Prints the
median and the fastest of the repeats (the runs alternate, so a busy machine slows both alike),
the ratio of the medians and, from inside the Python process, the import of numpy (a fixed cost
of any numpy program) and the settle_many call alone (numpy already imported, as in a notebook).
"""

import argparse
import csv
import os
import random
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import spherestep

ROOT = Path(__file__).resolve().parents[2]

# The timed Python process: read the sets, load the scenario, settle, use the columns.
CHILD = """
import sys, time
t0 = time.perf_counter()
import numpy
t1 = time.perf_counter()
import spherestep
sets_file, scenario = sys.argv[1], sys.argv[2]
with open(sets_file) as f:
    sets = [line.split("#")[0].strip() for line in f]
sets = [s for s in sets if s]
motor = spherestep.Scenario.load(scenario).motor()
t2 = time.perf_counter()
table = motor.settle_many(sets)
t3 = time.perf_counter()
settled = int(table.settled.sum())
q = table.q
print(len(table), settled, q.shape[0], t1 - t0, t3 - t2)
"""


def reachable_sets(sc, n, seed, reach_deg):
    """n sets of 2 to 4 distinct coils, each with a distinct magnet within reach_deg of it at
    the identity, as text `coil:magnet,coil:magnet`."""
    angle = np.degrees(np.arccos(np.clip(sc.stator @ sc.rotor.T, -1.0, 1.0)))
    rng = random.Random(seed)
    sets = []
    while len(sets) < n:
        coils = rng.sample(range(len(sc.stator)), rng.choice([2, 3, 4]))
        used, pairs = set(), []
        for c in coils:
            near = [int(j) for j in np.nonzero(angle[c] < reach_deg)[0] if int(j) not in used]
            if near:
                j = rng.choice(near)
                used.add(j)
                pairs.append(f"{c}:{j}")
        if len(pairs) >= 2:
            sets.append(",".join(pairs))
    return sets


def timed(cmd):
    t = time.perf_counter()
    p = subprocess.run(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    elapsed = time.perf_counter() - t
    if p.returncode != 0:
        sys.exit(f"{' '.join(map(str, cmd))} failed:\n{p.stderr}")
    return elapsed, p.stdout


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sets", type=int, default=10_000)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--scenario", type=Path, default=ROOT / "scenarios" / "prototype.toml")
    ap.add_argument("--bin", type=Path, default=ROOT / "target" / "release" / "spherestep")
    ap.add_argument("--reach-deg", type=float, default=30.0)
    a = ap.parse_args()
    sc = spherestep.Scenario.load(a.scenario)
    with tempfile.TemporaryDirectory(prefix="py-bench-") as tmp:
        sets_file = Path(tmp) / "sets.txt"
        sets = reachable_sets(sc, a.sets, a.seed, a.reach_deg)
        sets_file.write_text("\n".join(sets) + "\n")
        cli = [str(a.bin), "settle", str(a.scenario), "--sets", str(sets_file)]
        py = [sys.executable, "-c", CHILD, str(sets_file), str(a.scenario)]
        # the same numbers (not timed)
        _, text = timed(cli)
        rows = list(csv.DictReader(text.splitlines()))
        table = sc.motor().settle_many(sets)
        want = np.array([[float(r[k]) for k in ("qx", "qy", "qz", "qw")] for r in rows])
        if not (np.array_equal(table.q, want) and table.outcome == [r["outcome"] for r in rows]):
            sys.exit("settle_many and settle --sets disagree")
        times = {"cli": [], "python": [], "numpy": [], "call": []}
        for _ in range(a.repeats):
            times["cli"].append(timed(cli)[0])
            t, out = timed(py)
            times["python"].append(t)
            times["numpy"].append(float(out.split()[-2]))
            times["call"].append(float(out.split()[-1]))
    med = {k: statistics.median(v) for k, v in times.items()}
    print(
        f"{a.sets} sets ({sum(table.settled)} settled; mean {np.mean(table.evaluations):.0f} "
        f"evaluations), {os.cpu_count()} cores, {a.repeats} repeats, whole process:"
    )
    print(f"  spherestep settle --sets: median {med['cli']:.3f} s, fastest {min(times['cli']):.3f} s")
    print(f"  Python settle_many:       median {med['python']:.3f} s, fastest {min(times['python']):.3f} s")
    print(f"  ratio Python / command line (medians): {med['python'] / med['cli']:.3f}")
    print(
        f"inside the Python process: import numpy {med['numpy']:.3f} s, the settle_many call "
        f"{med['call']:.3f} s ({med['call'] / med['cli']:.3f} of the command line's whole process)"
    )

if __name__ == "__main__":
    main()
