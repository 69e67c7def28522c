"""Real parts (issue 33) against Magpylib: the well `spherestep wells` writes for a disc magnet
passing a thick winding (shape = "dipole", magnet_shape = "cylinder", coil_inner_radius_m,
coil_outer_radius_m, coil_length_m) is the torque Magpylib's getFT computes on the disc, meshed
into cells, in the exact field of the winding cut into 12 x 12 thin loops (the midpoint rule),
about the rotor centre: on three geometries, the curve within 1% of the peak, the peak and the
stiffness within 1%."""

import math

import pytest

from conftest import floats, read_csv, read_json

magpy = pytest.importorskip("magpylib")
np = pytest.importorskip("numpy")
Rotation = pytest.importorskip("scipy.spatial.transform").Rotation

MU0 = 4e-7 * math.pi

# (name, ball radius, disc diameter, disc thickness, remanence, inner radius, outer radius,
#  winding length, gap from the magnets' centres to the winding's face, ampere-turns, gain)
GEOMETRIES = [
    # the physical prototype: a 0.75 x 0.25 inch N42 disc, its real winding
    ("prototype", 0.1462, 0.01905, 0.00635, 1.3, 0.0095, 0.0254, 0.041, 0.0082, 1600.0, 4.0),
    # a small flat coil close to a thick disc
    ("flat", 0.05, 0.012, 0.008, 1.2, 0.003, 0.012, 0.006, 0.006, 500.0, 1.0),
    # a long coil with a wide bore, a thin disc farther out
    ("long", 0.2, 0.03, 0.004, 1.4, 0.02, 0.03, 0.06, 0.012, 3000.0, 2.0),
]

LOOPS = 12  # per direction of the winding's cross-section
MESH = (16, 6, 6)  # the disc's cells: around, across, through


def scenario(tmp_path, g):
    name, ball, dia, thick, br, r_in, r_out, length, gap, ni, gain = g
    text = f"""name = "real-{name}"
[rotor]
preset = "prototype"
[stator]
preset = "prototype"
[magnets]
shape = "dipole"
magnet_shape = "cylinder"
ball_radius_m = {ball}
remanence_t = {br}
magnet_diameter_m = {dia}
magnet_thickness_m = {thick}
coil_ampere_turns = {ni}
coil_inner_radius_m = {r_in}
coil_outer_radius_m = {r_out}
coil_length_m = {length}
gap_m = {gap}
core_gain = {gain}
max_attraction_deg = 60
"""
    path = tmp_path / f"real-{name}.toml"
    path.write_text(text)
    return path


def winding(g):
    """The winding as LOOPS x LOOPS circles of equal current (midpoint rule), on +Z."""
    _, ball, _, _, _, r_in, r_out, length, gap, ni, gain = g
    loops = []
    current = ni * gain / LOOPS**2
    for i in range(LOOPS):
        r = r_in + (i + 0.5) * (r_out - r_in) / LOOPS
        for j in range(LOOPS):
            z = ball + gap + (j + 0.5) * length / LOOPS
            loops.append(
                magpy.current.Circle(current=current, diameter=2 * r, position=(0, 0, z))
            )
    return magpy.Collection(*loops)


def pulls(g, angles_deg):
    """The pull (N m) on the disc at each angle (degrees) from the coil's axis: minus the y
    component of Magpylib's torque on it about the rotor centre."""
    _, ball, dia, thick, br, *_ = g
    coil = winding(g)
    out = []
    for d_deg in angles_deg:
        d = math.radians(d_deg)
        disc = magpy.magnet.Cylinder(
            polarization=(0, 0, br),
            dimension=(dia, thick),
            position=(ball * math.sin(d), 0, ball * math.cos(d)),
            orientation=Rotation.from_rotvec((0, d, 0)),
        )
        _, torque = magpy.getFT(coil, disc, pivot=(0, 0, 0), meshing=MESH, eps=1e-5 * dia)
        out.append(-float(np.asarray(torque).reshape(-1)[1]))
    return out


@pytest.mark.parametrize("g", GEOMETRIES, ids=[g[0] for g in GEOMETRIES])
def test_real_wells_match_magpylib(cli, tmp_path, g):
    path = scenario(tmp_path, g)
    out = tmp_path / "well.csv"
    summary = read_json(cli("wells", path, "--step-deg", "0.05", "--out", out, "--json"))
    rows = read_csv(out.read_text())
    angles, torques = floats(rows, "angle_deg"), floats(rows, "torque_nm")
    peak_deg = summary["peak_angle_deg"]
    # the curve from the axis out to three times the peak's angle, at 8 angles
    last = max(i for i, a in enumerate(angles) if a <= 3 * peak_deg)
    picked = [round(last * k / 8) for k in range(1, 9)]
    reference = pulls(g, [angles[i] for i in picked])
    peak = max(reference)
    worst = max(abs(torques[i] - r) for i, r in zip(picked, reference))
    ref_peak, ref_small = pulls(g, [peak_deg, 0.05])
    stiffness = ref_small / math.radians(0.05)
    print(
        f"{g[0]}: curve {worst / peak:.3%} of the peak, peak {summary['peak_torque_nm']:.5f} "
        f"against {ref_peak:.5f}, stiffness {summary['stiffness_nm_per_rad']:.4f} against "
        f"{stiffness:.4f}"
    )
    assert worst <= 0.01 * peak, f"{g[0]}: curve off by {worst / peak:.2%} of the peak"
    assert abs(summary["peak_torque_nm"] - ref_peak) <= 0.01 * ref_peak
    assert abs(summary["stiffness_nm_per_rad"] - stiffness) <= 0.01 * stiffness, (
        f"{g[0]}: stiffness {summary['stiffness_nm_per_rad']} against {stiffness}"
    )
