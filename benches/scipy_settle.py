#!/usr/bin/env python3
"""Settle the same active sets with spherestep (Rust) and with scipy's RK45, side by side.

Run from the repository root:

    python3 benches/scipy_settle.py                       # builds and runs the Rust example
    python3 benches/scipy_settle.py --rust-csv FILE.csv   # reuse a CSV from the example

The Rust side is `cargo run --release --example settle_sets -- SCENARIO --sets N --out CSV`
(research/settle_sets.rs): N deterministic 3-pair sets from one start orientation, settled one
after the other on one thread, one CSV row per set with the final orientation and the set's mean
time per settle.

The Python side is the same model written the way a user would with numpy and scipy (see
docs/model.md, "Pairs, coils, wells" and "Dynamics"):
  - pair torque (world) tau = (p x s) g(d)/sin d, p = R r_j, d = atan2(|p x s|, p.s), g = 0
    beyond the cut-off; gaussian U = -k exp(-d^2 / (2 sigma^2)) (or cosine U = -k cos d);
  - N_B = R^T sum tau, R the rotation of q/|q|;
  - dq/dt = 1/2 (q4 w - w x q), dq4/dt = -1/2 w.q, dw/dt = I^-1 [-w x (I w) + N_B - c w];
  - state (qx, qy, qz, qw, wx, wy, wz), start at rest; settled when |w| < omega_tol and
    |N_B| < torque_tol after an accepted step, with |N_B| recovered from the step's derivative
    (N_B = I dw/dt + w x (I w) + c w), as src/dynamics.rs does; not settled at t_max.
The RK45 solver object is stepped by hand and the settle test is applied after every step;
the "ivp" rows instead call solve_ivp with the settle test as a terminal event, as most users
would (slower: scipy locates the event's crossing on its dense output).

Each set is settled with scipy at (a) the scenario's rtol/atol and (b) rtol=1e-6, atol=1e-8,
timed with time.perf_counter, each with two right-hand sides computing the same numbers: numpy
arrays over the pairs (what one writes with numpy) and a loop in plain Python floats (faster for
3 pairs, where numpy's per-call cost dominates); --rhs picks one. The Rust time is taken over the
same sets (the CSV's per-set mean_us). The equilibria of (b) are compared with Rust's.
Exit status: 0 when every set that both settled agrees within --agree rad, 1 when not,
2 on a usage or setup error (e.g. scipy missing).
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
from dataclasses import dataclass
from pathlib import Path

try:
    import numpy as np
    from scipy.integrate import RK45, solve_ivp
except ImportError as e:  # pragma: no cover - depends on the machine
    print(
        f"scipy_settle.py: needs numpy and scipy ({e}); install them with\n"
        "    python3 -m pip install numpy scipy\nand run again.",
        file=sys.stderr,
    )
    sys.exit(2)

ROOT = Path(__file__).resolve().parent.parent
TIGHT = (1e-6, 1e-8)


class SetupError(Exception):
    """A problem with the arguments, the scenario or the Rust CSV (exit status 2)."""


# ---------------------------------------------------------------------------------------------
# The scenario, read as src/scenario.rs reads it (only what the settle needs).


@dataclass
class Model:
    rotor: np.ndarray  # (M, 3) unit vectors, body frame
    stator: np.ndarray  # (C, 3) unit vectors, world frame
    shape: str  # "gaussian" or "cosine"
    strength: float  # k, J
    width: float  # sigma, rad
    max_attraction: float  # d_max, rad
    inertia: np.ndarray  # (3,) kg m^2
    damping: float  # N m s / rad
    omega_tol: float
    torque_tol: float
    t_max: float
    rtol: float
    atol: float
    method: str  # the Rust integrator named by the scenario (reported only)
    notes: list[str]


def read_points(path: Path) -> np.ndarray:
    """A points CSV (header x,y,z), each row normalised as packing::parse_points_csv does."""
    rows = []
    try:
        with open(path, newline="") as f:
            r = csv.reader(f)
            header = next(r, None)
            if header is None:
                raise SetupError(f"{path}: empty, expected a header x,y,z and rows")
            for i, rec in enumerate(r, start=1):
                if not rec:
                    continue
                if len(rec) != 3:
                    raise SetupError(f"{path}: row {i}: expected 3 columns x,y,z")
                try:
                    v = [float(c) for c in rec]
                except ValueError:
                    raise SetupError(f"{path}: row {i}: expected numbers, got {rec}") from None
                n = math.sqrt(sum(c * c for c in v))
                if not (math.isfinite(n) and n >= 1e-12):
                    raise SetupError(f"{path}: row {i}: zero or non-finite vector")
                rows.append([c / n for c in v])
    except OSError as e:
        raise SetupError(f"cannot read {path}: {e}") from None
    if not rows:
        raise SetupError(f"{path}: no points")
    return np.array(rows, dtype=float)


def packing(raw: dict, section: str, scenario: Path) -> np.ndarray:
    unsupported = {"group", "generators", "cap_axis", "cap_deg"} & raw.keys()
    if unsupported:
        raise SetupError(
            f"{scenario}: [{section}] uses {sorted(unsupported)}; this script reads only "
            "preset = \"prototype\", points = [...] or file = \"...\""
        )
    if "points" in raw:
        pts = np.array(raw["points"], dtype=float)
        return pts / np.linalg.norm(pts, axis=1)[:, None]
    if "file" in raw:
        p = Path(raw["file"])
        return read_points(p if p.is_absolute() else scenario.parent / p)
    preset = raw.get("preset", "prototype")
    if preset != "prototype":
        raise SetupError(f"{scenario}: {section}.preset: only \"prototype\", got \"{preset}\"")
    # The preset is compiled in from these files (src/packing.rs include_str!), relative to the
    # crate root, not to the scenario: rotor in the body frame, stator in the world frame.
    return read_points(ROOT / "scenarios" / "prototype" / f"{section}.csv")


def load_model(path: Path) -> Model:
    try:
        with open(path, "rb") as f:
            raw = tomllib.load(f)
    except OSError as e:
        raise SetupError(f"cannot read scenario {path}: {e}") from None
    except tomllib.TOMLDecodeError as e:
        raise SetupError(f"{path}: not valid TOML: {e}") from None
    notes = []
    rotor = packing(raw.get("rotor", {}), "rotor", path)
    stator = packing(raw.get("stator", {}), "stator", path)
    mg = raw.get("magnets", {})
    shape = mg.get("shape", "gaussian")
    if shape not in ("gaussian", "cosine"):
        raise SetupError(f"{path}: magnets.shape = \"{shape}\": this script does gaussian, cosine")
    interaction = mg.get("interaction", "pairs")
    if interaction != "pairs":
        raise SetupError(
            f"{path}: magnets.interaction = \"{interaction}\": this script does \"pairs\" only"
        )
    body = raw.get("body", {})
    inertia = body.get("inertia_kg_m2", 0.023)
    inertia = np.array(
        [inertia] * 3 if isinstance(inertia, (int, float)) else inertia, dtype=float
    )
    st = raw.get("settle", {})
    rtol, atol = st.get("rtol"), st.get("atol")
    if rtol is None or atol is None:
        notes.append(
            "the scenario does not set settle.rtol/atol; (a) uses rtol=1e-2, atol=1e-5, "
            "the defaults of SettleParams when this script was written"
        )
        rtol = 1e-2 if rtol is None else rtol
        atol = 1e-5 if atol is None else atol
    return Model(
        rotor=rotor,
        stator=stator,
        shape=shape,
        strength=float(mg.get("strength_j", 0.25)),
        width=math.radians(float(mg.get("width_deg", 10.0))),
        max_attraction=math.radians(float(mg.get("max_attraction_deg", 30.0))),
        inertia=inertia,
        damping=float(body.get("damping_nms", 1.0)),
        omega_tol=float(st.get("omega_tol", 1e-3)),
        torque_tol=float(st.get("torque_tol", 1e-4)),
        t_max=float(st.get("t_max_s", 5.0)),
        rtol=float(rtol),
        atol=float(atol),
        method=str(st.get("method", "bs32")),
        notes=notes,
    )


# ---------------------------------------------------------------------------------------------
# The model in numpy.


def rotation_matrix(q) -> np.ndarray:
    """Body-to-world rotation of q/|q|, q = (x, y, z, w) (Hamilton)."""
    x, y, z, w = q
    s = 2.0 / (x * x + y * y + z * z + w * w)
    return np.array(
        [
            [1.0 - s * (y * y + z * z), s * (x * y - w * z), s * (x * z + w * y)],
            [s * (x * y + w * z), 1.0 - s * (x * x + z * z), s * (y * z - w * x)],
            [s * (x * z - w * y), s * (y * z + w * x), 1.0 - s * (x * x + y * y)],
        ]
    )


SMALL = 1e-7  # below this sin d, g(d)/sin d takes its limit (src/torque.rs)


class Dynamics:
    """The equations of motion of one active set, with two interchangeable right-hand sides:
    `rhs_numpy` (the pairs as arrays: how one writes it with numpy) and `rhs_float` (a loop over
    the pairs in plain Python floats, which for a handful of pairs beats numpy's per-call cost).
    Both compute the same numbers; the settle test is in plain floats."""

    def __init__(self, m: Model, pairs: list[tuple[int, int]]):
        self.m = m
        self.r = m.rotor[[j for _, j in pairs]]  # (k, 3) magnets, body frame
        self.s = m.stator[[i for i, _ in pairs]]  # (k, 3) coils, world frame
        self.rx, self.ry, self.rz = (self.r[:, i].copy() for i in range(3))
        self.pairs_f = [(tuple(a), tuple(b)) for a, b in zip(self.r.tolist(), self.s.tolist())]
        self.I = m.inertia
        self.Ix, self.Iy, self.Iz = (float(v) for v in m.inertia)
        self.c = m.damping
        self.k = m.strength
        self.s2 = m.width * m.width
        self.gauss = m.shape == "gaussian"
        self.dmax = m.max_attraction

    # -- numpy ------------------------------------------------------------------------------
    def body_torque(self, q) -> np.ndarray:
        """N_B = R^T sum_pairs (p x s) g(d)/sin d, computed in the body frame:
        R^T (R r x s) = r x R^T s."""
        R = rotation_matrix(q)
        sb = self.s @ R  # rows R^T s: the coils seen from the body
        sx, sy, sz = sb[:, 0], sb[:, 1], sb[:, 2]
        rx, ry, rz = self.rx, self.ry, self.rz
        xx, xy, xz = ry * sz - rz * sy, rz * sx - rx * sz, rx * sy - ry * sx
        sin_d = np.sqrt(xx * xx + xy * xy + xz * xz)
        d = np.arctan2(sin_d, rx * sx + ry * sy + rz * sz)
        small = sin_d < SMALL
        if self.gauss:
            # g(d)/sin d = k/sigma^2 (d/sin d) exp(-d^2/(2 sigma^2)); d/sin d -> 1 + d^2/6
            d_over_sin = np.where(small, 1.0 + d * d / 6.0, d / np.where(small, 1.0, sin_d))
            f = self.k / self.s2 * d_over_sin * np.exp(-d * d / (2.0 * self.s2))
        else:  # cosine: g = k sin d
            f = np.full(d.shape, self.k)
        # beyond the cut-off, and at the antipode (no defined direction): no pull
        f[(d > self.dmax) | (small & (d > 1.0))] = 0.0
        return np.array([f @ xx, f @ xy, f @ xz])

    def rhs_numpy(self, _t: float, y: np.ndarray) -> np.ndarray:
        qv, q4, w = y[0:3], y[3], y[4:7]
        wx, wy, wz = w
        qx, qy, qz = qv
        dq = 0.5 * (q4 * w - np.array([wy * qz - wz * qy, wz * qx - wx * qz, wx * qy - wy * qx]))
        dq4 = -0.5 * (w @ qv)
        nb = self.body_torque(y[0:4])
        Iw = self.I * w
        w_x_Iw = np.array(
            [wy * Iw[2] - wz * Iw[1], wz * Iw[0] - wx * Iw[2], wx * Iw[1] - wy * Iw[0]]
        )
        dw = (-w_x_Iw + nb - self.c * w) / self.I
        return np.concatenate((dq, [dq4], dw))

    # -- plain floats -----------------------------------------------------------------------
    def rhs_float(self, _t: float, y: np.ndarray) -> np.ndarray:
        qx, qy, qz, qw, wx, wy, wz = y.tolist()
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
        nx = ny = nz = 0.0
        k_s2, two_s2 = self.k / self.s2, 2.0 * self.s2
        for (ax, ay, az), (gx, gy, gz) in self.pairs_f:
            sx = r00 * gx + r10 * gy + r20 * gz  # R^T s
            sy = r01 * gx + r11 * gy + r21 * gz
            sz = r02 * gx + r12 * gy + r22 * gz
            xx, xy, xz = ay * sz - az * sy, az * sx - ax * sz, ax * sy - ay * sx
            sd = math.sqrt(xx * xx + xy * xy + xz * xz)
            d = math.atan2(sd, ax * sx + ay * sy + az * sz)
            if d > self.dmax or (sd < SMALL and d > 1.0):
                continue
            if self.gauss:
                dos = 1.0 + d * d / 6.0 if sd < SMALL else d / sd
                f = k_s2 * dos * math.exp(-d * d / two_s2)
            else:
                f = self.k
            nx += f * xx
            ny += f * xy
            nz += f * xz
        Ix, Iy, Iz, c = self.Ix, self.Iy, self.Iz, self.c
        return np.array(
            [
                0.5 * (qw * wx - (wy * qz - wz * qy)),
                0.5 * (qw * wy - (wz * qx - wx * qz)),
                0.5 * (qw * wz - (wx * qy - wy * qx)),
                -0.5 * (wx * qx + wy * qy + wz * qz),
                (-(wy * Iz * wz - wz * Iy * wy) + nx - c * wx) / Ix,
                (-(wz * Ix * wx - wx * Iz * wz) + ny - c * wy) / Iy,
                (-(wx * Iy * wy - wy * Ix * wx) + nz - c * wz) / Iz,
            ]
        )

    def settled(self, y: np.ndarray, dy: np.ndarray) -> bool:
        """|w| < omega_tol and |N_B| < torque_tol, N_B = I dw/dt + w x (I w) + c w."""
        _, _, _, _, wx, wy, wz = y.tolist()
        if math.sqrt(wx * wx + wy * wy + wz * wz) >= self.m.omega_tol:
            return False
        ax, ay, az = dy[4:7].tolist()
        Ix, Iy, Iz, c = self.Ix, self.Iy, self.Iz, self.c
        nx = Ix * ax + (wy * Iz * wz - wz * Iy * wy) + c * wx
        ny = Iy * ay + (wz * Ix * wx - wx * Iz * wz) + c * wy
        nz = Iz * az + (wx * Iy * wy - wy * Ix * wx) + c * wz
        return math.sqrt(nx * nx + ny * ny + nz * nz) < self.m.torque_tol


@dataclass
class PyResult:
    q: np.ndarray
    settled: bool
    nfev: int
    steps: int
    t: float
    seconds: float


def settle(m: Model, pairs, q0: np.ndarray, rtol: float, atol: float, rhs: str) -> PyResult:
    """Settle from rest at q0: RK45 stepped by hand, the settle test after each accepted step."""
    t0 = time.perf_counter()
    dyn = Dynamics(m, pairs)
    y0 = np.concatenate((q0, np.zeros(3)))
    if np.linalg.norm(dyn.body_torque(q0)) < m.torque_tol:
        # already in equilibrium and at rest (as src/dynamics.rs)
        return PyResult(q0 / np.linalg.norm(q0), True, 1, 0, 0.0, time.perf_counter() - t0)
    if rhs == "ivp":
        return settle_ivp(m, dyn, q0, y0, rtol, atol, t0)
    fun = dyn.rhs_numpy if rhs == "numpy" else dyn.rhs_float
    solver = RK45(fun, 0.0, y0, m.t_max, rtol=rtol, atol=atol)
    steps = 0
    ok = False
    while solver.status == "running":
        solver.step()
        if solver.status == "failed":
            break
        steps += 1
        if dyn.settled(solver.y, solver.f):  # solver.f: the derivative at the new y (FSAL)
            ok = True
            break
    q = solver.y[0:4] / np.linalg.norm(solver.y[0:4])
    return PyResult(q, ok, solver.nfev, steps, solver.t, time.perf_counter() - t0)


def settle_ivp(m: Model, dyn, q0, y0, rtol: float, atol: float, t0: float) -> PyResult:
    """What a user would write first: solve_ivp (RK45, numpy right-hand side) with the settle
    test as a terminal event, max(|w| / omega_tol, |N_B| / torque_tol) - 1 crossing zero
    downwards (scipy finds the crossing on its dense output; each event test costs a torque)."""

    def event(_t, y):
        w = np.linalg.norm(y[4:7])
        nb = np.linalg.norm(dyn.body_torque(y[0:4]))
        return max(w / m.omega_tol, nb / m.torque_tol) - 1.0

    event.terminal = True
    event.direction = -1
    sol = solve_ivp(
        dyn.rhs_numpy, (0.0, m.t_max), y0, method="RK45", rtol=rtol, atol=atol, events=event
    )
    y = sol.y[:, -1]
    ok = sol.status == 1
    return PyResult(
        y[0:4] / np.linalg.norm(y[0:4]), ok, sol.nfev, len(sol.t) - 1, sol.t[-1],
        time.perf_counter() - t0,
    )


def rotation_between(a: np.ndarray, b: np.ndarray) -> float:
    """Angle (rad) of the rotation taking orientation a to b, 2 acos(|a.b|) computed stably as
    2 atan2(|vec(a* b)|, |scal(a* b)|)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    # conj(a) * b, Hamilton
    w = aw * bw + ax * bx + ay * by + az * bz
    x = aw * bx - ax * bw - (ay * bz - az * by)
    y = aw * by - ay * bw - (az * bx - ax * bz)
    z = aw * bz - az * bw - (ax * by - ay * bx)
    return 2.0 * math.atan2(math.sqrt(x * x + y * y + z * z), abs(w))


# ---------------------------------------------------------------------------------------------
# The Rust side.


@dataclass
class RustRow:
    label: str
    pairs: list[tuple[int, int]]
    q0: np.ndarray
    q: np.ndarray
    settled: bool
    evaluations: int
    mean_us: float | None


def run_rust(scenario: Path, sets: int, out: Path) -> str:
    cmd = [
        "cargo", "run", "--release", "--example", "settle_sets", "--",
        str(scenario), "--sets", str(sets), "--out", str(out),
    ]
    print("$ " + " ".join(cmd), flush=True)
    try:
        p = subprocess.run(cmd, cwd=ROOT, stdout=subprocess.PIPE, text=True)
    except FileNotFoundError:
        raise SetupError("cargo not found on PATH (or pass --rust-csv FILE)") from None
    if p.returncode != 0:
        raise SetupError(f"the Rust example failed (exit status {p.returncode}):\n{p.stdout}")
    line = next((ln for ln in p.stdout.splitlines() if ln.startswith("rust:")), None)
    if line is None:
        raise SetupError(f"the Rust example printed no 'rust:' line:\n{p.stdout}")
    print(line, flush=True)
    return line


def parse_set(text: str, where: str) -> list[tuple[int, int]]:
    pairs = []
    for item in text.split(";"):
        c, sep, m = item.partition(":")
        if not sep:
            raise SetupError(f"{where}: set '{text}': expected coil:magnet;coil:magnet;...")
        try:
            pairs.append((int(c), int(m)))
        except ValueError:
            raise SetupError(f"{where}: set '{text}': expected integer indices") from None
    return pairs


def read_rust_csv(path: Path, m: Model) -> list[RustRow]:
    need = ["set", "qx0", "qy0", "qz0", "qw0", "qx", "qy", "qz", "qw", "settled", "evaluations"]
    rows = []
    try:
        with open(path, newline="") as f:
            r = csv.DictReader(f)
            missing = [c for c in need if c not in (r.fieldnames or [])]
            if missing:
                raise SetupError(f"{path}: missing columns {missing}")
            for i, rec in enumerate(r, start=1):
                where = f"{path}: row {i}"
                pairs = parse_set(rec["set"], where)
                for c, j in pairs:
                    if not (0 <= c < len(m.stator) and 0 <= j < len(m.rotor)):
                        raise SetupError(f"{where}: pair {c}:{j} is not on this motor")
                try:
                    q0 = np.array([float(rec[k]) for k in ("qx0", "qy0", "qz0", "qw0")])
                    q = np.array([float(rec[k]) for k in ("qx", "qy", "qz", "qw")])
                    ev = int(rec["evaluations"])
                    us = float(rec["mean_us"]) if rec.get("mean_us") else None
                except ValueError as e:
                    raise SetupError(f"{where}: {e}") from None
                if rec["settled"] not in ("true", "false"):
                    raise SetupError(f"{where}: settled must be true or false")
                rows.append(RustRow(rec["set"], pairs, q0, q, rec["settled"] == "true", ev, us))
    except OSError as e:
        raise SetupError(f"cannot read {path}: {e}") from None
    if not rows:
        raise SetupError(f"{path}: no sets")
    return rows


# ---------------------------------------------------------------------------------------------


def main() -> int:
    ap = argparse.ArgumentParser(
        description="Settle the same active sets with spherestep (Rust) and scipy RK45."
    )
    ap.add_argument(
        "--scenario",
        type=Path,
        default=ROOT / "scenarios" / "prototype.toml",
        help="scenario TOML (default scenarios/prototype.toml)",
    )
    ap.add_argument("--sets", type=int, default=200, help="sets the Rust example settles (200)")
    ap.add_argument("--rust-csv", type=Path, help="use this CSV of the example, do not run cargo")
    ap.add_argument(
        "--python-sets",
        type=int,
        default=0,
        help="settle only the first N sets with scipy (default 0: all of them)",
    )
    ap.add_argument(
        "--rhs",
        choices=["numpy", "float", "ivp", "all"],
        default="all",
        help="what to time: RK45 stepped by hand with a numpy or a plain-float right-hand side, "
        "solve_ivp with a terminal event (numpy), or all three (default)",
    )
    ap.add_argument(
        "--agree",
        type=float,
        default=1e-4,
        help="largest equilibrium disagreement (rad) counted as agreement (1e-4)",
    )
    a = ap.parse_args()
    if a.sets < 1 or a.python_sets < 0 or not a.agree > 0:
        ap.error("--sets must be >= 1, --python-sets >= 0 and --agree > 0")

    scenario = a.scenario.resolve()
    m = load_model(scenario)
    for n in m.notes:
        print(f"note: {n}")

    rust_line = None
    if a.rust_csv:
        rows = read_rust_csv(a.rust_csv, m)
    else:
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "settle_sets.csv"
            rust_line = run_rust(scenario, a.sets, out)
            rows = read_rust_csv(out, m)

    n_py = len(rows) if a.python_sets == 0 else min(a.python_sets, len(rows))
    subset = rows[:n_py]
    shown = scenario.relative_to(ROOT) if scenario.is_relative_to(ROOT) else scenario
    print(
        f"scenario {shown}: {len(m.rotor)} magnets, {len(m.stator)} coils, {m.shape} well "
        f"k={m.strength} J sigma={math.degrees(m.width):g} deg "
        f"cut-off={math.degrees(m.max_attraction):g} deg, I={m.inertia.tolist()} c={m.damping}; "
        f"settled when |w|<{m.omega_tol:g} and |N_B|<{m.torque_tol:g} by t_max={m.t_max:g} s; "
        f"Rust integrates with method \"{m.method}\" at rtol={m.rtol:g} atol={m.atol:g}"
    )
    print(
        f"python {sys.version.split()[0]}, numpy {np.__version__}, scipy "
        f"{__import__('scipy').__version__}: scipy settles "
        + (f"all {n_py}" if n_py == len(rows) else f"the first {n_py} of {len(rows)}")
        + " sets, one timed pass per configuration"
    )

    rhs_kinds = ["numpy", "float", "ivp"] if a.rhs == "all" else [a.rhs]
    configs = [
        (f"({tag}) {kind}", rtol, atol, kind)
        for kind in rhs_kinds
        for tag, rtol, atol in (("a", m.rtol, m.atol), ("b", *TIGHT))
    ]
    # warm-up outside the timing
    for kind in rhs_kinds:
        settle(m, subset[0].pairs, subset[0].q0, m.rtol, m.atol, kind)
    results: dict[str, list[PyResult]] = {}
    for name, rtol, atol, kind in configs:
        t0 = time.perf_counter()
        results[name] = [settle(m, r.pairs, r.q0, rtol, atol, kind) for r in subset]
        print(
            f"  scipy RK45 {name} rhs, rtol={rtol:g} atol={atol:g}: "
            f"{time.perf_counter() - t0:.1f} s",
            flush=True,
        )

    per_set_us = [r.mean_us for r in subset]
    if any(u is None for u in per_set_us):
        raise SetupError("the Rust CSV has no mean_us column: cannot time the Rust side")
    rust_us = sum(per_set_us) / len(per_set_us)
    rust_evals = sum(r.evaluations for r in subset) / len(subset)
    rust_settled = sum(r.settled for r in subset)

    def angles(res):
        return [
            (rotation_between(rr.q, pr.q), rr.label)
            for rr, pr in zip(subset, res)
            if rr.settled and pr.settled
        ]

    print()
    hdr = (
        f"{'engine':<42} {'sets':>5} {'settled':>7} {'mean per settle':>15} {'evals':>7} "
        f"{'x rust':>7} {'max angle vs rust':>17} {'both settled':>12}"
    )
    print(hdr)
    print("-" * len(hdr))
    print(
        f"{'rust ' + m.method + ' rtol=%g atol=%g' % (m.rtol, m.atol):<42} {len(subset):>5} "
        f"{rust_settled:>7} {rust_us:>12.2f} us {rust_evals:>7.1f} {'1':>7} {'-':>17} {'-':>12}"
    )
    summary = {}
    for name, rtol, atol, kind in configs:
        res = results[name]
        py_ms = 1e3 * sum(r.seconds for r in res) / len(res)
        ang = angles(res)
        worst = max(ang) if ang else (float("nan"), "-")
        summary[name] = (py_ms, worst)
        print(
            f"{'scipy RK45 ' + name + ' rtol=%g atol=%g' % (rtol, atol):<42} {len(res):>5} "
            f"{sum(r.settled for r in res):>7} {py_ms:>12.2f} ms "
            f"{sum(r.nfev for r in res) / len(res):>7.1f} {py_ms * 1e3 / rust_us:>7.0f} "
            f"{worst[0]:>17.2e} {len(ang):>12}"
        )
    print()
    if rust_line is not None:
        print(f"rust over all {len(rows)} sets, as the example printed it: {rust_line}")
    print(f"ratios (python mean / rust mean over the same {len(subset)} sets):")
    for name, rtol, atol, kind in configs:
        ratio = summary[name][0] * 1e3 / rust_us
        print(f"  scipy {name:<9} rtol={rtol:<6g} atol={atol:<6g}: {ratio:8.0f}x")

    status = 0
    for name, _, _, _ in configs:
        if not name.startswith("(b)"):
            continue
        res = results[name]
        ang = angles(res)
        worst = summary[name][1]
        beyond = sorted((x for x in ang if x[0] > a.agree), reverse=True)
        print(
            f"largest equilibrium disagreement, scipy {name} (tight) vs rust: {worst[0]:.3e} rad "
            f"(set {worst[1]}), over {len(ang)} sets both settled; "
            f"{len(beyond)} beyond {a.agree:g} rad"
        )
        for x, label in beyond[:10]:
            print(f"  disagree: {label}: {x:.3e} rad")
        one_side = [
            f"{rr.label} (rust {'yes' if rr.settled else 'no'})"
            for rr, pr in zip(subset, res)
            if rr.settled != pr.settled
        ]
        if one_side:
            print(f"  settled by one side only ({len(one_side)}): {', '.join(one_side[:10])}")
        if beyond:
            status = 1
    not_settled = [rr.label for rr in subset if not rr.settled]
    if not_settled:
        print(
            f"rust did not settle {len(not_settled)} of {len(subset)} sets within t_max "
            f"(left out of the comparison): {', '.join(not_settled[:10])}"
            + (" ..." if len(not_settled) > 10 else "")
        )
    return status


if __name__ == "__main__":
    try:
        sys.exit(main())
    except SetupError as e:
        print(f"scipy_settle.py: error: {e}", file=sys.stderr)
        sys.exit(2)
    except KeyboardInterrupt:
        sys.exit(130)
