"""Bad input raises spherestep.Error (a ValueError) with a clear message, the library's, and
never crashes the interpreter."""

import math

import numpy as np
import pytest

import spherestep
from conftest import SCENARIOS


@pytest.fixture(scope="module")
def motor():
    return spherestep.Scenario.prototype().motor()


def test_error_is_a_value_error():
    assert issubclass(spherestep.Error, ValueError)
    assert spherestep.Error.__module__ == "spherestep"


def test_missing_scenario_file_names_the_file(tmp_path):
    missing = tmp_path / "nowhere.toml"
    with pytest.raises(spherestep.Error, match="nowhere.toml"):
        spherestep.Scenario.load(missing)


def test_scenario_field_not_allowed_names_the_field():
    with pytest.raises(spherestep.Error, match=r"mine\.toml: field `body.damping_nms`"):
        spherestep.Scenario.from_toml("[body]\ndamping_nms = -1\n", "mine.toml")


def test_scenario_syntax_and_unknown_keys():
    with pytest.raises(spherestep.Error, match="<string>"):
        spherestep.Scenario.from_toml("[body\n")
    with pytest.raises(spherestep.Error, match="unknown field"):
        spherestep.Scenario.from_toml("[body]\nmass = 3\n")


@pytest.mark.parametrize(
    "pairs, message",
    [
        ("0:14,99:3", r"argument pairs: expected coil index below 16 .* got 99 in pair 99:3"),
        ([(0, 14), (3, 80)], r"magnet index below 80 .* got 80"),
        ("0:14,0:15", "each coil at most once, got coil 0 twice"),
        ("0:x", "pairs written coil:magnet,coil:magnet .* got '0:x'"),
        ("", "got nothing"),
        ([], "got no pairs"),
        ([(0, -1)], r"integers >= 0, got \(0, -1\) as pair 0"),
        ([(0, 1.5)], r"got \(0, 1.5\) as pair 0"),
        ([(0, 1, 2)], "as pair 0"),
        (np.zeros((3, 3), dtype=int), r"an array of shape \(3, 3\)"),
        (np.zeros(2, dtype=int), r"an array of shape \(2,\)"),
        (7, "got 7"),
    ],
)
def test_bad_pairs(motor, pairs, message):
    with pytest.raises(spherestep.Error, match=message):
        motor.settle(pairs)


@pytest.mark.parametrize(
    "q0, message",
    [
        ([0.0, 0.0, 0.0, math.nan], r"a non-zero, finite quaternion qx,qy,qz,qw, got \[0, 0, 0, NaN\]"),
        ([0, 0, 0, 0], "non-zero, finite quaternion"),
        ([0, 0, math.inf, 1], "non-zero, finite quaternion"),
        ([0, 0, 1], r"4 numbers qx,qy,qz,qw, got 3 values"),
        (np.ones((4, 1)), r"4 numbers qx,qy,qz,qw, got an array of shape \(4, 1\)"),
        (np.ones((1, 4)), r"an array of shape \(1, 4\)"),
        ("0,0,0,1", "got the text"),
        ([[0], [0], [0], [1]], "4 numbers qx,qy,qz,qw"),
    ],
)
def test_bad_start_orientation(motor, q0, message):
    with pytest.raises(spherestep.Error, match="argument q0: expected .*" + message):
        motor.settle("0:14", q0=q0)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"axis": (0, 0, 0)}, "argument axis: expected a non-zero, finite vector"),
        ({"axis": (math.nan, 1, 0)}, "argument axis: expected a non-zero, finite vector"),
        ({"axis": np.eye(3)}, r"argument axis: expected 3 numbers x,y,z, got an array of shape \(3, 3\)"),
        ({"angle": 0}, r"argument angle: expected a target angle in \(0, 180\]"),
        ({"angle": math.nan}, "argument angle: expected a target angle"),
        ({"angle": 270}, "plan it as moves of at most 180 degrees"),
        ({"scheme": "fastest"}, "argument scheme: expected one of min-axis-error, max-angle"),
        ({"model": "magic"}, "argument model: expected pivot, dynamic or coils, got 'magic'"),
        ({"model": "pivot", "pairs": 3}, "2 pairs per step for the pivot model, got 3"),
        ({"pairs": "2-9"}, "2 to 8 pairs per step for the dynamic model"),
        ({"pairs": "many"}, "argument pairs: expected K"),
        ({"to": (0, 0, 0, 1)}, "argument to: expected an orientation other than the start"),
        ({"to": (0, 0, 0.5, 1), "angle": 30}, "a target orientation or an axis and an angle, not both"),
        ({"start": (1, 2, math.nan, 4)}, "argument start: expected a non-zero, finite quaternion"),
    ],
)
def test_bad_plan_arguments(motor, kwargs, message):
    with pytest.raises(spherestep.Error, match=message):
        motor.plan(**kwargs)


def test_settle_many_names_the_bad_set(motor):
    with pytest.raises(spherestep.Error, match=r"argument sets\[2\]: expected coil index below 16"):
        motor.settle_many(["0:14", "1:3", "16:0"])
    with pytest.raises(spherestep.Error, match="one set: use settle"):
        motor.settle_many("0:14")
    with pytest.raises(spherestep.Error, match="argument threads: expected at least 1 and at most 1024 worker threads, got 0"):
        motor.settle_many(["0:14"], threads=0)
    with pytest.raises(spherestep.Error, match="got -2"):
        motor.settle_many(["0:14"], threads=-2)
    with pytest.raises(spherestep.Error, match="got 100000"):
        motor.settle_many(["0:14"], threads=100_000)
    with pytest.raises(spherestep.Error, match="argument q0"):
        motor.settle_many(["0:14"], q0=[math.nan, 0, 0, 1])


def test_wells_step_out_of_range(motor):
    with pytest.raises(spherestep.Error, match="`step_deg`: expected"):
        motor.wells(0.0)
    with pytest.raises(spherestep.Error, match="`step_deg`"):
        motor.wells(math.nan)


def test_simulate_bad_plans(motor, tmp_path):
    with pytest.raises(spherestep.Error, match="missing.csv"):
        motor.simulate(tmp_path / "missing.csv")
    broken = tmp_path / "broken.csv"
    broken.write_text("step,qx\n0,1\n")
    with pytest.raises(spherestep.Error, match="broken.csv: .*pivot_coil"):
        motor.simulate(broken)
    with pytest.raises(spherestep.Error, match="argument plan: expected a Plan or the path"):
        motor.simulate(42)
    # a plan made for another motor: its pairs are checked against this one
    small = spherestep.Scenario.from_toml(
        '[stator]\npreset = "prototype"\n[rotor]\npoints = [[0, 0, -1], [1, 0, 0], [0, 1, 0]]\n'
    ).motor()
    plan_file = tmp_path / "plan.csv"
    motor.plan(axis=(0, 0, 1), angle=30).to_csv(plan_file)
    with pytest.raises(spherestep.Error, match=r"plan.csv: line 2: .*magnet index below 3"):
        small.simulate(plan_file)


def test_a_plant_with_other_packings_is_refused(motor):
    other = spherestep.Scenario.from_toml(
        '[rotor]\npoints = [[0, 0, -1], [1, 0, 0], [0, 1, 0]]\n', "other.toml"
    ).motor()
    plan = motor.plan(axis=(0, 0, 1), angle=30)
    with pytest.raises(spherestep.Error, match="argument plant: expected a plant with the plan's packings"):
        motor.simulate(plan, plant=other)
    with pytest.raises(spherestep.Error, match="other magnet count"):
        motor.run(other)


def test_bad_run_options(motor):
    with pytest.raises(spherestep.Error, match=r"argument sensor_noise_deg: expected a noise in \[0, 10\]"):
        motor.run(closed_loop=True, sensor_noise_deg=11)
    with pytest.raises(spherestep.Error, match="sensor_noise_deg"):
        motor.run(closed_loop=True, sensor_noise_deg=math.nan)
    with pytest.raises(spherestep.Error, match="argument max_steps: expected a whole number >= 1"):
        motor.run(closed_loop=True, max_steps=0)
    with pytest.raises(spherestep.Error, match="argument max_steps: expected a whole number >= 1, got -3"):
        motor.run(closed_loop=True, max_steps=-3)
    with pytest.raises(spherestep.Error, match=r"argument seed: expected a whole number in \[0, 2\^64\), got -1"):
        motor.run(closed_loop=True, seed=-1)
    for kwargs in [{"max_steps": 5}, {"sensor_noise_deg": 1.0}, {"seed": 2}, {"identify": False}]:
        with pytest.raises(spherestep.Error, match="argument closed_loop: expected True with sensor_noise_deg"):
            motor.run(**kwargs)


def test_to_csv_never_overwrites_the_scenario(tmp_path):
    toml = tmp_path / "s.toml"
    toml.write_text((SCENARIOS / "prototype.toml").read_text())
    sc = spherestep.Scenario.load(toml)
    plan = sc.motor().plan(axis=(0, 0, 1), angle=30)
    with pytest.raises(spherestep.Error, match="`out`"):
        plan.to_csv(toml)
    (tmp_path / "taken").mkdir()
    with pytest.raises(spherestep.Error, match="taken"):
        plan.to_csv(tmp_path / "taken")  # a folder, not a file
    plan.to_csv(tmp_path / "new" / "p.csv")  # a missing folder is made
    assert (tmp_path / "new" / "p.csv").read_text() == plan.csv()
