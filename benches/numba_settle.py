#!/usr/bin/env python3
"""Settle the same active sets with spherestep (Rust) and with a compiled peer: the same model
with Dormand-Prince 5(4) and a standard step-size controller, compiled with numba.

Run from the repository root (needs python3 >= 3.11 and PyPI; nothing else):

    python3 benches/numba_settle.py [--sets N] [--scenario FILE] [--planner [--seed S]]

`--planner`: the planner-like sets instead (`settle_sets --planner`: each from its
own random start, three pairs within 24 degrees of their coils), read back from the Rust
example's CSV (set and start), by default on benches/planner-sets.toml:

    python3 benches/numba_settle.py --planner --sets 4000

The script creates its own virtual environment (target/numba-venv, or $NUMBA_VENV),
pip-installs numba and numpy there, and runs itself again inside it. Both sides run on one
thread:

- spherestep: `cargo run --release --example settle_sets -- SCENARIO --sets N --out CSV` with
  RAYON_NUM_THREADS=1 (research/settle_sets.rs: N deterministic 3-pair sets from one start,
  settled one after the other, each set's mean time per settle over repeated passes);
- numba: the model of docs/model.md (pair torque (p x s) g(d)/sin d, gaussian or cosine
  wells with their cut-off, N_B = R^T sum, dq/dt = 1/2 (q4 w - w x q), dq4/dt = -1/2 w.q,
  dw/dt = I^-1 [-w x I w + N_B - c w]) integrated by Dopri5 (Hairer's coefficients, FSAL, PI
  controller with Hairer's defaults: safety 0.9, beta 0.04, step factors 0.2 to 10, his starting
  step), the settle test |w| < omega_tol and |N_B| < torque_tol after every accepted step, at the
  scenario's rtol/atol, each set timed over repeated calls after compilation.

Prints both times per settle (mean and median over the sets), both evaluation counts, the ratio,
and the worst disagreement of the final orientations (sets that both settle). Exit status 0, or 2
on a setup error.
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
VENV = Path(os.environ.get("NUMBA_VENV", ROOT / "target" / "numba-venv"))


def ensure_venv() -> None:
    """Re-runs this script inside target/numba-venv, creating it (numba, numpy) if needed."""
    if Path(sys.prefix).resolve() == VENV.resolve():
        return
    py = VENV / "bin" / "python"
    if not py.exists():
        print(f"creating {VENV} and installing numba, numpy ...", file=sys.stderr)
        subprocess.run([sys.executable, "-m", "venv", str(VENV)], check=True)
    probe = subprocess.run([str(py), "-c", "import numba, numpy"], capture_output=True)
    if probe.returncode != 0:
        subprocess.run(
            [str(py), "-m", "pip", "install", "--quiet", "numba", "numpy"], check=True
        )
    os.execv(str(py), [str(py), __file__, *sys.argv[1:]])


ensure_venv()
# numba's compiled cache goes under target/, not next to this script
os.environ.setdefault("NUMBA_CACHE_DIR", str(ROOT / "target" / "numba-cache"))

import numba  # noqa: E402
import numpy as np  # noqa: E402
from numba import njit  # noqa: E402


class SetupError(Exception):
    pass


# ---------------------------------------------------------------------------------------------
# The scenario (the prototype's presets, or points/file), as src/scenario.rs reads it.


def read_points(path: Path) -> np.ndarray:
    with open(path, newline="") as f:
        rows = list(csv.reader(f))[1:]
    pts = np.array([[float(c) for c in r] for r in rows if r], dtype=float)
    return pts / np.linalg.norm(pts, axis=1)[:, None]


def packing(raw: dict, section: str, scenario: Path) -> np.ndarray:
    if "points" in raw:
        pts = np.array(raw["points"], dtype=float)
        return pts / np.linalg.norm(pts, axis=1)[:, None]
    if "file" in raw:
        p = Path(raw["file"])
        return read_points(p if p.is_absolute() else scenario.parent / p)
    if raw.get("preset", "prototype") != "prototype" or {"group", "generators"} & raw.keys():
        raise SetupError(f"{scenario}: [{section}]: only the prototype preset, points or file")
    return read_points(ROOT / "scenarios" / "prototype" / f"{section}.csv")


def load(path: Path) -> dict:
    with open(path, "rb") as f:
        raw = tomllib.load(f)
    mg, body, st = raw.get("magnets", {}), raw.get("body", {}), raw.get("settle", {})
    if mg.get("interaction", "pairs") != "pairs":
        raise SetupError("only interaction = \"pairs\"")
    shape = mg.get("shape", "gaussian")
    if shape not in ("gaussian", "cosine"):
        raise SetupError("only gaussian and cosine wells")
    inertia = body.get("inertia_kg_m2", 0.023)
    inertia = [inertia] * 3 if isinstance(inertia, (int, float)) else inertia
    return dict(
        rotor=packing(raw.get("rotor", {}), "rotor", path),
        stator=packing(raw.get("stator", {}), "stator", path),
        gauss=shape == "gaussian",
        k=float(mg.get("strength_j", 0.25)),
        sigma=math.radians(float(mg.get("width_deg", 10.0))),
        dmax=math.radians(float(mg.get("max_attraction_deg", 30.0))),
        inertia=np.array(inertia, dtype=float),
        c=float(body.get("damping_nms", 1.0)),
        omega_tol=float(st.get("omega_tol", 1e-3)),
        torque_tol=float(st.get("torque_tol", 1e-4)),
        t_max=float(st.get("t_max_s", 5.0)),
        rtol=float(st.get("rtol", 1e-2)),
        atol=float(st.get("atol", 1e-5)),
    )


def quat_rotate(q, v):
    """Rotates v by the unit quaternion q = (x, y, z, w)."""
    x, y, z, w = q
    u = np.array([x, y, z])
    return v + 2.0 * np.cross(u, np.cross(u, v) + w * v)


def build_sets(m: dict, q0, n: int) -> list[list[tuple[int, int]]]:
    """research/settle_sets.rs: ordered triples of distinct coils, each with its nearest magnet."""
    p = np.array([quat_rotate(q0, r) for r in m["rotor"]])
    near = [int(np.argmax(p @ s)) for s in m["stator"]]
    coils = len(m["stator"])
    sets = []
    for a in range(coils):
        for b in range(coils):
            for c in range(coils):
                if a != b and b != c and a != c:
                    sets.append([(a, near[a]), (b, near[b]), (c, near[c])])
                    if len(sets) == n:
                        return sets
    return sets


# ---------------------------------------------------------------------------------------------
# The model and Dopri5 in numba.


@njit(cache=True, fastmath=False)
def rhs(y, dy, r, s, gauss, k, s2, dmax, inertia, c):
    qx, qy, qz, qw = y[0], y[1], y[2], y[3]
    wx, wy, wz = y[4], y[5], y[6]
    sn = 2.0 / (qx * qx + qy * qy + qz * qz + qw * qw)
    r00 = 1.0 - sn * (qy * qy + qz * qz)
    r01 = sn * (qx * qy - qw * qz)
    r02 = sn * (qx * qz + qw * qy)
    r10 = sn * (qx * qy + qw * qz)
    r11 = 1.0 - sn * (qx * qx + qz * qz)
    r12 = sn * (qy * qz - qw * qx)
    r20 = sn * (qx * qz - qw * qy)
    r21 = sn * (qy * qz + qw * qx)
    r22 = 1.0 - sn * (qx * qx + qy * qy)
    nx = 0.0
    ny = 0.0
    nz = 0.0
    for i in range(r.shape[0]):
        ax, ay, az = r[i, 0], r[i, 1], r[i, 2]
        gx, gy, gz = s[i, 0], s[i, 1], s[i, 2]
        sx = r00 * gx + r10 * gy + r20 * gz
        sy = r01 * gx + r11 * gy + r21 * gz
        sz = r02 * gx + r12 * gy + r22 * gz
        xx = ay * sz - az * sy
        xy = az * sx - ax * sz
        xz = ax * sy - ay * sx
        sd = math.sqrt(xx * xx + xy * xy + xz * xz)
        d = math.atan2(sd, ax * sx + ay * sy + az * sz)
        if d > dmax or (sd < 1e-7 and d > 1.0):
            continue
        if gauss:
            dos = 1.0 + d * d / 6.0 if sd < 1e-7 else d / sd
            f = k / s2 * dos * math.exp(-d * d / (2.0 * s2))
        else:
            f = k
        nx += f * xx
        ny += f * xy
        nz += f * xz
    ix, iy, iz = inertia[0], inertia[1], inertia[2]
    dy[0] = 0.5 * (qw * wx - (wy * qz - wz * qy))
    dy[1] = 0.5 * (qw * wy - (wz * qx - wx * qz))
    dy[2] = 0.5 * (qw * wz - (wx * qy - wy * qx))
    dy[3] = -0.5 * (wx * qx + wy * qy + wz * qz)
    dy[4] = (-(wy * iz * wz - wz * iy * wy) + nx - c * wx) / ix
    dy[5] = (-(wz * ix * wx - wx * iz * wz) + ny - c * wy) / iy
    dy[6] = (-(wx * iy * wy - wy * ix * wx) + nz - c * wz) / iz


@njit(cache=True)
def settled(y, dy, inertia, c, omega_tol, torque_tol):
    wx, wy, wz = y[4], y[5], y[6]
    if math.sqrt(wx * wx + wy * wy + wz * wz) >= omega_tol:
        return False
    ix, iy, iz = inertia[0], inertia[1], inertia[2]
    nx = ix * dy[4] + (wy * iz * wz - wz * iy * wy) + c * wx
    ny = iy * dy[5] + (wz * ix * wx - wx * iz * wz) + c * wy
    nz = iz * dy[6] + (wx * iy * wy - wy * ix * wx) + c * wz
    return math.sqrt(nx * nx + ny * ny + nz * nz) < torque_tol


@njit(cache=True)
def settle(y0, r, s, gauss, k, s2, dmax, inertia, c, omega_tol, torque_tol, t_max, rtol, atol):
    """Dopri5 until the settle test passes: (y, t, evaluations, settled)."""
    a21 = 1.0 / 5.0
    a31, a32 = 3.0 / 40.0, 9.0 / 40.0
    a41, a42, a43 = 44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0
    a51, a52, a53, a54 = 19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0
    a61, a62, a63, a64, a65 = (
        9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0, -5103.0 / 18656.0)
    a71, a73, a74, a75, a76 = (
        35.0 / 384.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0)
    e1, e3, e4, e5, e6, e7 = (
        71.0 / 57600.0, -71.0 / 16695.0, 71.0 / 1920.0, -17253.0 / 339200.0, 22.0 / 525.0,
        -1.0 / 40.0)
    n = 7
    y = y0.copy()
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    k5 = np.empty(n)
    k6 = np.empty(n)
    k7 = np.empty(n)
    yt = np.empty(n)
    ynew = np.empty(n)
    rhs(y, k1, r, s, gauss, k, s2, dmax, inertia, c)
    evals = 1
    if settled(y, k1, inertia, c, omega_tol, torque_tol):
        return y, 0.0, evals, True
    # Hairer's starting step (order 5)
    d0 = 0.0
    d1 = 0.0
    for i in range(n):
        sc = atol + rtol * abs(y[i])
        d0 += (y[i] / sc) ** 2
        d1 += (k1[i] / sc) ** 2
    d0 = math.sqrt(d0 / n)
    d1 = math.sqrt(d1 / n)
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    h0 = min(h0, t_max)
    for i in range(n):
        yt[i] = y[i] + h0 * k1[i]
    rhs(yt, k2, r, s, gauss, k, s2, dmax, inertia, c)
    evals += 1
    d2 = 0.0
    for i in range(n):
        sc = atol + rtol * abs(y[i])
        d2 += ((k2[i] - k1[i]) / sc) ** 2
    d2 = math.sqrt(d2 / n) / h0
    dm = max(d1, d2)
    h1 = max(1e-6, h0 * 1e-3) if dm <= 1e-15 else (0.01 / dm) ** 0.2
    h = min(100.0 * h0, h1, t_max)
    t = 0.0
    beta = 0.04
    alpha = 0.2 - 0.75 * beta
    err_old = 1e-4
    rejected = False
    while t < t_max:
        if t + h > t_max:
            h = t_max - t
        for i in range(n):
            yt[i] = y[i] + h * a21 * k1[i]
        rhs(yt, k2, r, s, gauss, k, s2, dmax, inertia, c)
        for i in range(n):
            yt[i] = y[i] + h * (a31 * k1[i] + a32 * k2[i])
        rhs(yt, k3, r, s, gauss, k, s2, dmax, inertia, c)
        for i in range(n):
            yt[i] = y[i] + h * (a41 * k1[i] + a42 * k2[i] + a43 * k3[i])
        rhs(yt, k4, r, s, gauss, k, s2, dmax, inertia, c)
        for i in range(n):
            yt[i] = y[i] + h * (a51 * k1[i] + a52 * k2[i] + a53 * k3[i] + a54 * k4[i])
        rhs(yt, k5, r, s, gauss, k, s2, dmax, inertia, c)
        for i in range(n):
            yt[i] = y[i] + h * (a61 * k1[i] + a62 * k2[i] + a63 * k3[i] + a64 * k4[i]
                                + a65 * k5[i])
        rhs(yt, k6, r, s, gauss, k, s2, dmax, inertia, c)
        for i in range(n):
            ynew[i] = y[i] + h * (a71 * k1[i] + a73 * k3[i] + a74 * k4[i] + a75 * k5[i]
                                  + a76 * k6[i])
        rhs(ynew, k7, r, s, gauss, k, s2, dmax, inertia, c)
        evals += 6
        err = 0.0
        for i in range(n):
            sc = atol + rtol * max(abs(y[i]), abs(ynew[i]))
            e = h * (e1 * k1[i] + e3 * k3[i] + e4 * k4[i] + e5 * k5[i] + e6 * k6[i]
                     + e7 * k7[i])
            err += (e / sc) ** 2
        err = math.sqrt(err / n)
        if err <= 1.0:
            fac = 0.9 * err ** (-alpha) * err_old ** beta if err > 0.0 else 10.0
            fac = min(10.0, max(0.2, fac))
            if rejected:
                fac = min(1.0, fac)
            err_old = max(err, 1e-4)
            t += h
            for i in range(n):
                y[i] = ynew[i]
                k1[i] = k7[i]
            if settled(y, k1, inertia, c, omega_tol, torque_tol):
                return y, t, evals, True
            h *= fac
            rejected = False
        else:
            h *= max(0.2, 0.9 * err ** (-alpha))
            rejected = True
            if h < 1e-14 * t_max:
                break
    return y, t, evals, False


# ---------------------------------------------------------------------------------------------


def run_rust(scenario: Path, n: int, planner: list[str]) -> list[dict]:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "rust.csv"
        env = dict(os.environ, RAYON_NUM_THREADS="1")
        cmd = ["cargo", "run", "--quiet", "--release", "--example", "settle_sets", "--",
               str(scenario), "--sets", str(n), *planner, "--out", str(out)]
        print("$ RAYON_NUM_THREADS=1 " + " ".join(cmd), file=sys.stderr)
        subprocess.run(cmd, cwd=ROOT, env=env, check=True, stdout=sys.stderr)
        with open(out, newline="") as f:
            return list(csv.DictReader(f))


def angle_between(a, b) -> float:
    d = abs(float(np.dot(a, b))) / (np.linalg.norm(a) * np.linalg.norm(b))
    return 2.0 * math.acos(min(1.0, d))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sets", type=int, default=200)
    ap.add_argument("--scenario", type=Path, default=None,
                    help="default scenarios/prototype.toml, with --planner benches/planner-sets.toml")
    ap.add_argument("--planner", action="store_true",
                    help="the planner-like sets of settle_sets --planner, read from its CSV")
    ap.add_argument("--seed", type=int, default=32, help="their seed (with --planner)")
    ap.add_argument("--min-time", type=float, default=0.05,
                    help="seconds of repeated calls per set for the numba timing")
    args = ap.parse_args()
    if args.scenario is None:
        args.scenario = ROOT / ("benches/planner-sets.toml" if args.planner
                                else "scenarios/prototype.toml")
    try:
        m = load(args.scenario)
    except (OSError, SetupError, tomllib.TOMLDecodeError) as e:
        print(f"numba_settle.py: {e}", file=sys.stderr)
        return 2
    numba.set_num_threads(1)
    planner = ["--planner", "--seed", str(args.seed)] if args.planner else []
    rust = run_rust(args.scenario, args.sets, planner)
    starts = [np.array([float(row[c]) for c in ("qx0", "qy0", "qz0", "qw0")]) for row in rust]
    if args.planner:
        sets = [[tuple(int(v) for v in p.split(":")) for p in row["set"].split(";")]
                for row in rust]
    else:
        sets = build_sets(m, starts[0], args.sets)
    labels = [";".join(f"{c}:{j}" for c, j in s) for s in sets]
    if labels != [row["set"] for row in rust]:
        print("numba_settle.py: the sets differ from the Rust example's", file=sys.stderr)
        return 2
    s2 = m["sigma"] ** 2
    consts = (m["gauss"], m["k"], s2, m["dmax"], m["inertia"], m["c"], m["omega_tol"],
              m["torque_tol"], m["t_max"], m["rtol"], m["atol"])
    t_compile = time.perf_counter()
    r0 = np.ascontiguousarray(m["rotor"][[j for _, j in sets[0]]])
    s0 = np.ascontiguousarray(m["stator"][[c for c, _ in sets[0]]])
    y0 = np.array([*starts[0], 0.0, 0.0, 0.0])
    settle(y0, r0, s0, *consts)
    t_compile = time.perf_counter() - t_compile
    py_us, py_ev, worst, both = [], [], 0.0, 0
    for set_, row, q0 in zip(sets, rust, starts):
        y0 = np.array([q0[0], q0[1], q0[2], q0[3], 0.0, 0.0, 0.0])
        r = np.ascontiguousarray(m["rotor"][[j for _, j in set_]])
        s = np.ascontiguousarray(m["stator"][[c for c, _ in set_]])
        y, t, ev, ok = settle(y0, r, s, *consts)
        reps, start = 0, time.perf_counter()
        while True:
            settle(y0, r, s, *consts)
            reps += 1
            el = time.perf_counter() - start
            if el >= args.min_time:
                break
        py_us.append(el / reps * 1e6)
        py_ev.append(ev)
        if ok and row["settled"] == "true":
            both += 1
            qr = np.array([float(row[c]) for c in ("qx", "qy", "qz", "qw")])
            worst = max(worst, angle_between(y[:4], qr))
    rs_us = [float(row["mean_us"]) for row in rust]
    rs_ev = [int(row["evaluations"]) for row in rust]
    med = lambda v: float(np.median(v))  # noqa: E731
    mean = lambda v: float(np.mean(v))  # noqa: E731
    p99 = lambda v: float(np.percentile(v, 99, method="inverted_cdf"))  # noqa: E731
    n = len(sets)
    kind = "planner-like " if args.planner else ""
    print(f"{n} {kind}3-pair sets of {args.scenario.name}, one thread each; numba "
          f"{numba.__version__}, numpy {np.__version__}, python {sys.version.split()[0]} "
          f"(compile {t_compile:.1f} s)")
    print(f"{'engine':<44} {'mean us':>9} {'median us':>10} {'p99 us':>9} {'mean evals':>11} "
          f"{'median evals':>13} {'p99 evals':>10}")
    for label, us, ev in (("spherestep (research/settle_sets.rs)", rs_us, rs_ev),
                          (f"numba Dopri5, rtol {m['rtol']:g} atol {m['atol']:g}", py_us, py_ev)):
        print(f"{label:<44} {mean(us):9.2f} {med(us):10.2f} {p99(us):9.2f} {mean(ev):11.1f} "
              f"{med(ev):13.0f} {p99(ev):10.0f}")
    print(f"spherestep is {mean(py_us) / mean(rs_us):.2f}x faster (mean), "
          f"{med(py_us) / med(rs_us):.2f}x (median)")
    print(f"worst disagreement of the final orientations ({both} sets settled by both): "
          f"{worst:.2e} rad")
    return 0


if __name__ == "__main__":
    sys.exit(main())
