"""The calls a lab's notebook uses for parameter studies: Scenario.replace, the prototype's
name and a text's path, Motor.pairs_within, the plan's pairs as signed index arrays and the
closed loop of a plan from Motor.simulate, each against the command line's bytes where it has
the same, and each refusing bad input with spherestep.Error."""

import math
import re

import numpy as np
import pytest

import spherestep
from conftest import SCENARIOS, floats, read_csv, read_json

PLANT = SCENARIOS / "plants" / "prototype-worn.toml"


@pytest.fixture(scope="module")
def motor():
    return spherestep.Scenario.prototype().motor()


def test_text_names_no_file_and_the_prototype_is_named_as_its_file(prototype_toml):
    sc = spherestep.Scenario.from_toml('name = "mine"\n')
    assert sc.path is None and sc.name == "mine" and "path=None" in repr(sc)
    assert str(spherestep.Scenario.from_toml("", "mine.toml").path) == "mine.toml"
    proto = spherestep.Scenario.prototype()
    loaded = spherestep.Scenario.load(prototype_toml)
    assert proto.path is None
    assert (proto.name, proto.description) == (loaded.name, loaded.description)
    assert proto.name == "prototype" and "80 magnets" in proto.description
    # errors in text still say which text
    with pytest.raises(spherestep.Error, match="<string>"):
        spherestep.Scenario.from_toml("[body]\ndamping = -1\n")


def test_replace_changes_values_as_the_file_would(cli, prototype_toml, tmp_path):
    sc = spherestep.Scenario.load(prototype_toml)
    changed = sc.replace({"body.damping_nms": 0.8}, magnets={"width_deg": 9.0}, name="study")
    assert changed.name == "study" and changed.path == sc.path
    assert sc.name == "prototype"  # the original is unchanged
    # the same scenario written as a file, on the command line: the same bytes
    f = tmp_path / "study.toml"
    f.write_text(changed.toml)
    again = spherestep.Scenario.load(f)
    assert again.name == "study"
    out = tmp_path / "plan.csv"
    cli("plan", f, "--axis", "0,1,0", "--angle", "45", "--out", out, ok=False)
    plan = changed.motor().plan(axis=(0, 1, 0), angle=45)
    assert plan.csv() == out.read_text()
    assert plan.csv() != sc.motor().plan(axis=(0, 1, 0), angle=45).csv()
    settled = read_json(cli("settle", f, "--pairs", "0:14,12:26", "--json"))
    r = changed.motor().settle("0:14,12:26")
    assert r.q.tolist() == settled["q"]
    # None restores the default; an integer stays one
    assert sc.replace(name=None).name == "prototype"  # the file's stem
    assert changed.replace({"body.damping_nms": None}).motor().settle("0:14,12:26").q.tolist() == (
        sc.replace(magnets={"width_deg": 9.0}).motor().settle("0:14,12:26").q.tolist()
    )
    angled = spherestep.Scenario.prototype().replace({"plan.angle_deg": np.int64(45)})
    assert "angle_deg = 45\n" in angled.toml and angled.name == "prototype"


@pytest.mark.parametrize(
    "changes, kwargs, key",
    [
        ({"body.damping_nms_": 1.0}, {}, "body.damping_nms_"),
        ({}, {"bdy": {"damping_nms": 1.0}}, "bdy.damping_nms"),
        ({"colour": "red"}, {}, "colour"),
        ({"body.damping_nms": -1.0}, {}, "body.damping_nms"),
        ({"body.damping_nms": "lots"}, {}, "body.damping_nms"),
        ({"body..damping_nms": 1.0}, {}, "body..damping_nms"),
        ({"body.damping_nms": object()}, {}, "body.damping_nms"),
        ({"name.first": "x"}, {}, "name.first"),
    ],
)
def test_replace_refuses_unknown_keys_and_bad_values_naming_the_key(changes, kwargs, key):
    with pytest.raises(spherestep.Error, match=f"argument {re.escape(key)}: expected"):
        spherestep.Scenario.prototype().replace(changes, **kwargs)
    with pytest.raises(spherestep.Error, match="keys as text"):
        spherestep.Scenario.prototype().replace({1: 2})


def _angle(a, b):
    return math.degrees(math.acos(max(-1.0, min(1.0, float(np.dot(a, b))))))


def _rotate(q, v):
    x, y, z, w = q
    u = np.array([x, y, z])
    return v + 2 * np.cross(u, np.cross(u, v) + w * v)


def test_pairs_within_reach(motor):
    sc = motor.scenario
    q = spherestep.quat_from_axis_angle((1, 2, 3), 40)
    for reach in (10.0, 30.0):
        pairs = motor.pairs_within(reach, q)
        want = [
            (c, m)
            for c, s in enumerate(sc.stator)
            for m, p in enumerate(sc.rotor)
            if _angle(_rotate(q, p), s) <= reach + 1e-9
        ]
        # the same pairs as numpy finds, but for a pair within 1e-9 degrees of the edge
        assert set(pairs) ^ set(want) <= {
            (c, m) for c, m in want if abs(_angle(_rotate(q, sc.rotor[m]), sc.stator[c]) - reach) < 1e-9
        }
        assert pairs == sorted(pairs)
    assert motor.pairs_within(0.0) == [] or all(c >= 0 for c, _ in motor.pairs_within(0.0))
    assert len(motor.pairs_within(180)) == motor.coils * motor.magnets
    # by default the coil's reach: the pairs a settle counts as holding
    r = motor.settle("0:14,12:26")
    within = set(motor.pairs_within(q=r.q))
    assert set(r.held) <= within and not set(r.not_held) & within
    for bad in (-1, 181, float("nan"), float("inf")):
        with pytest.raises(spherestep.Error, match="argument reach_deg: expected an angle"):
            motor.pairs_within(bad)
    with pytest.raises(spherestep.Error, match="argument q: expected"):
        motor.pairs_within(30, q=(0, 0, 0, 0))


def test_the_plans_pairs_as_index_arrays_match_the_cli(cli, prototype_toml, tmp_path):
    out = tmp_path / "plan.csv"
    cli("plan", prototype_toml, "--axis", "0,1,0", "--angle", "90", "--out", out)
    plan = spherestep.Scenario.load(prototype_toml).motor().plan(axis=(0, 1, 0), angle=90)
    rows = read_csv(out.read_text())
    assert plan.pivot_coil.dtype == np.int64 and plan.active_magnet.dtype == np.int64
    assert plan.pivot_coil.tolist() == [int(r["pivot_coil"] or -1) for r in rows]
    assert plan.pivot_magnet.tolist() == [int(r["pivot_magnet"] or -1) for r in rows]
    assert plan.active_magnet.shape == plan.new_magnet.shape == (len(plan), 16)
    for k, r in enumerate(rows):
        active = [tuple(map(int, p.split(":"))) for p in r["active"].split(";")]
        assert [(c, int(m)) for c, m in enumerate(plan.active_magnet[k]) if m >= 0] == sorted(active)
        coils = [int(c) for c in r["new_coil"].split(";") if c]
        magnets = [int(m) for m in r["new_magnet"].split(";") if m]
        assert [(c, int(m)) for c, m in enumerate(plan.new_magnet[k]) if m >= 0] == sorted(zip(coils, magnets))
        assert plan.pivot[k] == (None if plan.pivot_coil[k] < 0 else (plan.pivot_coil[k], plan.pivot_magnet[k]))


def test_settle_tables_sets_as_index_arrays(motor):
    sets = ["0:14,12:26", "3:40,9:12,14:2", "5:5"]
    t = motor.settle_many(sets)
    a = t.active_magnet
    assert a.shape == (3, 16) and a.dtype == np.int64 and not a.flags.writeable
    for k, s in enumerate(sets):
        pairs = sorted(tuple(map(int, p.split(":"))) for p in s.split(","))
        assert [(c, int(m)) for c, m in enumerate(a[k]) if m >= 0] == pairs == sorted(t.active[k])


def test_closed_loop_simulation_matches_the_cli(cli, prototype_toml, tmp_path):
    m = spherestep.Scenario.load(prototype_toml).motor()
    plant = spherestep.Scenario.load(PLANT).motor()
    plan_file = tmp_path / "plan.csv"
    m.plan(axis=(0, 1, 0), angle=90).to_csv(plan_file)
    out = tmp_path / "loop.csv"
    args = ["--closed-loop", "--sensor-noise-deg", "0.5", "--seed", "3", "--out", out, "--json"]
    summary = read_json(cli("simulate", plan_file, prototype_toml, "--plant", PLANT, *args, ok=False))
    run = m.simulate(plan_file, plant, closed_loop=True, sensor_noise_deg=0.5, seed=3)
    assert isinstance(run, spherestep.Run)
    assert run.csv() == out.read_text()
    assert run.true_q.tolist() == [[float(r[k]) for k in ("true_qx", "true_qy", "true_qz", "true_qw")] for r in read_csv(out.read_text())]
    for k in summary:
        if not k.startswith("replan_ms"):  # wall time, reported, never decided on
            assert run.summary[k] == summary[k], k
    # with another step model for the replans, as --model
    out2 = tmp_path / "loop2.csv"
    cli("simulate", plan_file, prototype_toml, "--plant", PLANT, "--closed-loop", "--model", "pivot", "--out", out2, ok=False)
    assert m.simulate(plan_file, plant, closed_loop=True, model="pivot").csv() == out2.read_text()
    # what was on, as index arrays beside the tuples (and the CSV's active column)
    rows = read_csv(out.read_text())
    assert run.active_magnet.shape == (len(run), 16) and run.active_magnet.dtype == np.int64
    for k, r in enumerate(rows):
        on = sorted(tuple(map(int, p.split(":"))) for p in r["active"].split(";") if p)
        assert [(c, int(m)) for c, m in enumerate(run.active_magnet[k]) if m >= 0] == on
        assert sorted(run.active[k]) == on
    # open loop it stays a Simulation
    assert isinstance(m.simulate(plan_file, plant), spherestep.Simulation)


def test_closed_loop_simulation_refuses_bad_options(motor, tmp_path):
    plan = motor.plan(axis=(0, 0, 1), angle=30)
    for kwargs, words in [
        ({"sensor_noise_deg": 0.5}, "argument closed_loop: expected True"),
        ({"model": "pivot"}, "argument model: expected closed_loop=True"),
        ({"closed_loop": True, "model": "magic"}, "argument model"),
        ({"closed_loop": True, "sensor_noise_deg": -1.0}, "argument sensor_noise_deg"),
        ({"closed_loop": True, "sensor_noise_deg": float("nan")}, "argument sensor_noise_deg"),
        ({"closed_loop": True, "seed": -1}, "argument seed"),
        ({"closed_loop": True, "max_steps": 0}, "argument max_steps"),
    ]:
        with pytest.raises(spherestep.Error, match=words):
            motor.simulate(plan, closed_loop=True, **{k: v for k, v in kwargs.items() if k != "closed_loop"}) if kwargs.get("closed_loop") else motor.simulate(plan, **kwargs)
    # a plan that does not turn the ball has no target to aim at
    still = tmp_path / "still.csv"
    lines = plan.csv().splitlines()
    still.write_text("\n".join(lines[:2]) + "\n")
    with pytest.raises(spherestep.Error):
        motor.simulate(str(still), closed_loop=True)
