"""The paper's Figure 8 from Python: the cumulative axis error against the cumulative rotation
angle of a 90 degree turn about Y on the prototype, one line per scheme, with the paper's 15
degree bound (Stein & Chirikjian, section 4.1).

Left, the paper's own planners: the pivot model with two pairs, its three greedy schemes and the
search (scenarios/paper-fig8-y.toml; the Rust side draws the same lines as
results/paper-fig8-y-schemes.png). Right, the dynamic model with three pairs per step
(scenarios/paper-fig8-y-dynamic3.toml, results/paper-fig8-y-dynamic3-error.png) and the default
planner (2 to 4 pairs), each replayed through the dynamics (the crosses: where the ball really
settles, measured from the plan's start).

    pip install matplotlib
    python python/examples/figure8.py [--out figure8.png]
"""

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import spherestep  # noqa: E402

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"
SCHEMES = ["min-axis-error", "max-angle", "weighted", "search"]
STYLE = {
    "min-axis-error": ("o", "-", 11),
    "max-angle": ("s", "--", 9),
    "weighted": ("^", "-.", 7),
    "search": ("D", ":", 5),
}


def quat_mul(a, b):
    """Hamilton products of [x, y, z, w] quaternions (rows)."""
    ax, ay, az, aw = np.moveaxis(a, -1, 0)
    bx, by, bz, bw = np.moveaxis(b, -1, 0)
    return np.stack(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ],
        axis=-1,
    )


def cumulative(q, axis):
    """The rotation from row 0 to each row, R_k R_0^T: its angle about `axis` and its axis
    error, degrees (docs/model.md, "Figures of merit"; no unwrapping past 180 needed here)."""
    q0_inv = q[0] * np.array([-1, -1, -1, 1])
    d = quat_mul(q, q0_inv)
    d = d * np.sign(d[:, 3:4] + (d[:, 3:4] == 0))
    v = d[:, :3]
    s = np.linalg.norm(v, axis=1)
    angle = np.degrees(2 * np.arctan2(s, d[:, 3]))
    with np.errstate(invalid="ignore", divide="ignore"):
        cosine = (v @ axis) / s
    error = np.degrees(np.arccos(np.clip(np.where(s > 0, cosine, 1.0), -1, 1)))
    sign = np.where(error > 90, -1.0, 1.0)
    return sign * angle, np.where(error > 90, 180 - error, error)


def panel(ax, title, lines, bound=15.0, target=90.0):
    ax.axhline(bound, color="0.4", ls="--", lw=2, label=f"paper, Figure 8: {bound:g} deg")
    ax.axvline(target, color="0.5", ls="--", lw=0.8)
    ax.text(target, 19.5, f"target {target:g} deg", ha="center", va="top", fontsize=8, color="0.4")
    for label, x, y, (marker, ls, size), extra in lines:
        ax.plot(x, y, ls=ls, marker=marker, ms=size, mfc="none", lw=1, label=label, **extra)
    ax.set(
        title=title,
        xlabel="cumulative rotation angle (deg)",
        ylabel="cumulative axis error (deg)",
        xlim=(-1, 120),
        ylim=(-0.5, 20),
    )
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", fontsize=8)


def main():
    ap = argparse.ArgumentParser(description="The paper's Figure 8 from Python")
    ap.add_argument("--out", type=Path, default=Path("figure8.png"))
    out = ap.parse_args().out

    pivot = spherestep.Scenario.load(SCENARIOS / "paper-fig8-y.toml").motor()
    left = []
    for scheme in SCHEMES:
        p = pivot.plan(scheme=scheme)
        left.append((scheme, p.cum_angle_deg, p.cum_axis_error_deg, STYLE[scheme], {}))
        print(f"pivot, {scheme:>14}: {p}")

    y = np.array([0.0, 1.0, 0.0])
    right = []
    for label, toml, style in [
        ("dynamic, 3 pairs (search)", "paper-fig8-y-dynamic3.toml", ("D", ":", 6)),
        ("default: dynamic, 2-4 pairs", "prototype.toml", ("o", "-", 9)),
    ]:
        motor = spherestep.Scenario.load(SCENARIOS / toml).motor()
        p = motor.plan(axis=y, angle=90)
        sim = motor.simulate(p)
        angle, error = cumulative(sim.q, y)
        right.append((label, p.cum_angle_deg, p.cum_axis_error_deg, style, {}))
        # one legend entry for the replays (simulate: where the ball really settles)
        replayed = "replayed through the dynamics" if not right[:-1] else "_nolegend_"
        right.append((replayed, angle, error, ("x", "none", 7), {"color": "k"}))
        print(f"{label:>28}: {p}; replayed: {sim}")

    fig, axes = plt.subplots(1, 2, figsize=(13, 5), sharey=True)
    panel(axes[0], "90 deg about Y: pivot model, 2 pairs (the paper's schemes)", left)
    panel(axes[1], "90 deg about Y: dynamic model, replayed", right)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
