"""The API as a notebook uses it: the tabular results as dicts, DataFrames and HTML tables,
len() and the repr agreeing, signed step numbers, the prototype's path, settle_many with a
start per set, and the two orientation helpers."""

import html.parser
import math
import re
import sys

import numpy as np
import pytest

import spherestep
from conftest import SCENARIOS

H = math.sqrt(0.5)


@pytest.fixture(scope="module")
def motor():
    return spherestep.Scenario.prototype().motor()


@pytest.fixture(scope="module")
def plan(motor):
    return motor.plan(axis=(0, 0, 1), angle=90)


@pytest.fixture(scope="module")
def results(motor, plan):
    """One of each tabular result, with its expected columns (name -> what the attributes
    say, as lists)."""
    sim = motor.simulate(plan)
    run = motor.run(axis=(0, 0, 1), angle=45)
    table = motor.settle_many(["0:14,12:26", "3:40,9:12,14:2", "5:5"])
    wells = motor.wells(0.1)

    def q(prefix, a):
        return {f"{prefix}{k}": a[:, i].tolist() for i, k in enumerate(["qx", "qy", "qz", "qw"])}

    return {
        "Plan": (
            plan,
            {
                "step": plan.step.tolist(),
                "pivot": plan.pivot,
                "new": plan.new,
                "active": plan.active,
                **q("", plan.q),
                "step_angle_deg": plan.step_angle_deg.tolist(),
                "step_axis_error_deg": plan.step_axis_error_deg.tolist(),
                "cum_angle_deg": plan.cum_angle_deg.tolist(),
                "cum_axis_error_deg": plan.cum_axis_error_deg.tolist(),
                "settle_time_s": plan.settle_time_s.tolist(),
                "settled": plan.settled.tolist(),
            },
        ),
        "Simulation": (
            sim,
            {
                "step": sim.step.tolist(),
                **q("", sim.q),
                "deviation_deg": sim.deviation_deg.tolist(),
                "settled": sim.settled.tolist(),
                "settle_time_s": sim.settle_time_s.tolist(),
            },
        ),
        "Run": (
            run,
            {
                "step": run.step.tolist(),
                "active": run.active,
                "replanned": run.replanned.tolist(),
                **q("planned_", run.planned_q),
                **q("measured_", run.measured_q),
                **q("true_", run.true_q),
                "cum_angle_deg": run.cum_angle_deg.tolist(),
                "cum_axis_error_deg": run.cum_axis_error_deg.tolist(),
                "error_to_goal_deg": run.error_to_goal_deg.tolist(),
                "settled": run.settled.tolist(),
                "settle_time_s": run.settle_time_s.tolist(),
            },
        ),
        "SettleTable": (
            table,
            {
                "active": table.active,
                **q("", table.q),
                "settle_time_s": table.settle_time_s.tolist(),
                "evaluations": table.evaluations.tolist(),
                "steps": table.steps.tolist(),
                "energy_j": table.energy_j.tolist(),
                "residual_torque_nm": table.residual_torque_nm.tolist(),
                "settled": table.settled.tolist(),
                "outcome": table.outcome,
                "held": table.held,
            },
        ),
        "Wells": (
            wells,
            {"angle_deg": wells.angle_deg.tolist(), "torque_nm": wells.torque_nm.tolist()},
        ),
    }


KINDS = ["Plan", "Simulation", "Run", "SettleTable", "Wells"]


@pytest.mark.parametrize("kind", KINDS)
def test_to_dict_is_the_columns_in_order(results, kind):
    r, expected = results[kind]
    d = r.to_dict()
    assert list(d) == list(expected)
    assert d == expected
    assert all(type(v) is list and len(v) == len(r) for v in d.values())
    if "step" in d:
        assert all(type(s) is int for s in d["step"]) and d["step"][0] == 0


@pytest.mark.parametrize("kind", KINDS)
def test_to_pandas_is_the_dict_as_a_dataframe(results, kind):
    pd = pytest.importorskip("pandas")
    r, expected = results[kind]
    df = r.to_pandas()
    assert isinstance(df, pd.DataFrame)
    assert df.shape == (len(r), len(expected)) and list(df.columns) == list(expected)
    for name, values in expected.items():
        assert df[name].tolist() == values, name
    if "step" in expected:
        assert df["step"].dtype == np.int64 and (df["step"] - 1).iloc[0] == -1
    if "settled" in expected:
        assert df["settled"].dtype == np.bool_


def test_to_pandas_without_pandas_says_how_to_install_it(monkeypatch, plan):
    # None in sys.modules makes `import pandas` raise ImportError, as if it were missing
    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(ImportError, match=r"Plan\.to_pandas\(\) needs pandas.*pip install pandas"):
        plan.to_pandas()


class _Table(html.parser.HTMLParser):
    """The caption, header cells and body rows (cell texts) of an HTML table."""

    def __init__(self):
        super().__init__()
        self.caption, self.header, self.rows = "", [], []
        self.where, self.cell = None, None

    def handle_starttag(self, tag, attrs):
        if tag in ("thead", "tbody", "caption"):
            self.where = tag
        elif tag == "tr" and self.where == "tbody":
            self.rows.append([])
        elif tag in ("th", "td"):
            self.cell = ""

    def handle_endtag(self, tag):
        if tag in ("th", "td"):
            (self.header if self.where == "thead" else self.rows[-1]).append(self.cell)
            self.cell = None
        elif tag == "caption":
            self.where = None

    def handle_data(self, data):
        if self.cell is not None:
            self.cell += data
        elif self.where == "caption":
            self.caption += data


def _cell(x):
    if x is None:
        return ""
    if isinstance(x, float):
        return format(x, ".6g")
    return str(x)


@pytest.mark.parametrize("kind", ["Plan", "Simulation", "Run", "SettleTable"])
def test_repr_html_is_a_table_of_the_rows(results, kind):
    r, expected = results[kind]
    t = _Table()
    t.feed(r._repr_html_())
    assert t.caption == repr(r)
    assert t.header == ["", *expected]
    assert len(t.rows) == len(r)
    for k, row in enumerate(t.rows):
        assert row == [str(k), *(_cell(v[k]) for v in expected.values())], k


def test_repr_html_of_a_long_table_shows_its_ends(results):
    w, expected = results["Wells"]
    n = len(w)
    assert n == 301  # every 0.1 degrees from 0 to 30
    t = _Table()
    t.feed(w._repr_html_())
    assert len(t.rows) == 41
    assert [row[0] for row in t.rows] == [
        *map(str, range(20)),
        "\u2026",
        *map(str, range(n - 20, n)),
    ]
    assert t.rows[-1] == [str(n - 1), "30", _cell(expected["torque_nm"][-1])]


def test_repr_html_has_no_markup_but_its_own(results):
    # the pairs' and words' texts hold no character HTML gives a meaning to, and the tags are
    # the table's own: nothing between them is markup
    for kind in KINDS:
        h = results[kind][0]._repr_html_()
        text = re.sub(r"</?(table|caption|thead|tbody|tr|th|td)( class=\"spherestep\")?>", "", h)
        assert not set("<>\"'") & set(text), kind


@pytest.mark.parametrize("kind", ["Plan", "Simulation", "Run"])
def test_len_is_the_rows_and_the_repr_says_so(results, kind):
    r, _ = results[kind]
    m = re.search(
        r"\((?:open loop, )?(\d+) steps? \((\d+) rows?, row 0 the initial commutation\)", repr(r)
    )
    assert m, repr(r)
    steps, rows = int(m.group(1)), int(m.group(2))
    assert rows == len(r) == steps + 1 == r.summary["steps"] + 1
    assert r.step.tolist() == list(range(len(r)))


def test_step_columns_are_signed(results):
    for kind in ["Plan", "Simulation", "Run"]:
        r, _ = results[kind]
        assert r.step.dtype == np.int64, kind
        assert (r.step - 1)[0] == -1, kind
        assert np.diff(r.step).tolist() == [1] * (len(r) - 1)


def test_the_prototypes_path_is_none(prototype_toml):
    sc = spherestep.Scenario.prototype()
    assert sc.path is None
    assert sc.motor().scenario.path is None
    assert "path=None" in repr(sc)
    loaded = spherestep.Scenario.load(prototype_toml)
    assert str(loaded.path) == str(prototype_toml)
    assert f'path="{prototype_toml}"' in repr(loaded)
    assert spherestep.Scenario.from_toml("").path is None
    assert str(spherestep.Scenario.from_toml("", "mine.toml").path) == "mine.toml"


SETS = ["0:14,12:26", "3:40,9:12,14:2", [(0, 14)], "5:5,7:30"]
STARTS = [[0, 0, 0, 1], [0.1, -0.2, 0.05, 0.97], [0.0, 0.3, 0.0, 0.95], [0.2, 0.0, -0.1, 0.9]]


@pytest.mark.parametrize("form", [list, tuple, np.array])
def test_settle_many_with_a_start_per_set(motor, form):
    t = motor.settle_many(SETS, q0=form([form(q) for q in STARTS]))
    for k, (s, q0) in enumerate(zip(SETS, STARTS)):
        r = motor.settle(s, q0=q0)
        assert t.q[k].tolist() == r.q.tolist(), k
        assert t.settle_time_s[k] == r.settle_time_s and t.evaluations[k] == r.evaluations
    # the starts matter: not all the same as from the identity
    same = motor.settle_many(SETS)
    assert t.q[0].tolist() == same.q[0].tolist()
    assert t.q[1].tolist() != same.q[1].tolist()
    # and the results are the same on any number of threads
    one = motor.settle_many(SETS, q0=STARTS, threads=1)
    np.testing.assert_array_equal(one.q, t.q)


def test_settle_many_with_one_start_still_settles_all_from_it(motor):
    q0 = STARTS[1]
    t = motor.settle_many(SETS, q0=q0)
    u = motor.settle_many(SETS, q0=[q0] * len(SETS))
    np.testing.assert_array_equal(t.q, u.q)
    assert t.q[2].tolist() == motor.settle(SETS[2], q0=q0).q.tolist()
    # any iterable, a generator too
    w = motor.settle_many(SETS, q0=(x for x in q0))
    np.testing.assert_array_equal(w.q, t.q)
    g = motor.settle_many(SETS, q0=(q for q in STARTS))
    np.testing.assert_array_equal(g.q, motor.settle_many(SETS, q0=STARTS).q)
    # four sets and four numbers: one start, not a start per set
    v = motor.settle_many(SETS, q0=np.array(q0))
    np.testing.assert_array_equal(v.q, t.q)


def test_settle_many_refuses_starts_that_are_not_one_per_set(motor):
    with pytest.raises(
        ValueError,
        match=r"argument q0: expected one start for all the sets, or one start per set \(4 sets\), got 3 starts",
    ):
        motor.settle_many(SETS, q0=STARTS[:3])
    with pytest.raises(spherestep.Error, match=r"got 2 starts"):
        motor.settle_many(SETS, q0=np.zeros((2, 4)) + [0, 0, 0, 1])
    with pytest.raises(spherestep.Error, match=r"argument q0\[1\]: expected 4 numbers"):
        motor.settle_many(SETS, q0=[STARTS[0], [1, 2, 3], STARTS[2], STARTS[3]])
    with pytest.raises(spherestep.Error, match=r"argument q0\[2\]: expected a non-zero, finite"):
        motor.settle_many(SETS, q0=[STARTS[0], STARTS[1], [0, 0, 0, math.nan], STARTS[3]])
    with pytest.raises(
        spherestep.Error,
        match=r"argument q0: expected .* an array of shape \(4, 4\), one start per set, got an array of shape \(4, 3\)",
    ):
        motor.settle_many(SETS, q0=np.ones((4, 3)))


def test_quat_from_axis_angle():
    assert spherestep.quat_from_axis_angle((0, 0, 1), 90) == pytest.approx((0, 0, H, H), abs=1e-15)
    # any length of axis; x, y, z, w order; right-handed
    assert spherestep.quat_from_axis_angle([2, 0, 0], 60) == pytest.approx(
        (0.5, 0, 0, math.sqrt(0.75)), abs=1e-15
    )
    assert spherestep.quat_from_axis_angle(np.array([0, -1.0, 0]), 90) == pytest.approx(
        (0, -H, 0, H), abs=1e-15
    )
    # qw >= 0 as every orientation the package returns: 270 about Z is -90 about Z
    assert spherestep.quat_from_axis_angle((0, 0, 1), 270) == pytest.approx(
        (0, 0, -H, H), abs=1e-15
    )
    assert spherestep.quat_from_axis_angle((0, 0, 1), 0) == (0.0, 0.0, 0.0, 1.0)
    with pytest.raises(spherestep.Error, match="argument axis: expected a non-zero, finite vector"):
        spherestep.quat_from_axis_angle((0, 0, 0), 10)
    with pytest.raises(
        spherestep.Error, match="argument angle_deg: expected a finite number of degrees, got nan"
    ):
        spherestep.quat_from_axis_angle((0, 0, 1), math.nan)
    with pytest.raises(spherestep.Error, match="argument angle_deg"):
        spherestep.quat_from_axis_angle((0, 0, 1), "90")


def test_angle_between():
    ident = [0, 0, 0, 1]
    assert spherestep.angle_between(
        ident, spherestep.quat_from_axis_angle((1, 1, 0), 37)
    ) == pytest.approx(37, abs=1e-12)
    # x, y, z, w: [1, 0, 0, 0] is half a turn about X (w first, it would be the identity)
    assert spherestep.angle_between(ident, [1, 0, 0, 0]) == pytest.approx(180, abs=1e-12)
    # q and -q are one orientation; the angle is the same either way and between any pair
    a = spherestep.quat_from_axis_angle((0.3, -1, 2), 50)
    b = spherestep.quat_from_axis_angle((1, 0.2, 0), -70)
    ab = spherestep.angle_between(a, b)
    assert spherestep.angle_between([-x for x in a], b) == pytest.approx(ab, abs=1e-12)
    assert spherestep.angle_between(b, a) == pytest.approx(ab, abs=1e-12)
    assert spherestep.angle_between(a, a) == 0.0
    # accurate near 0, where acos is not
    tiny = spherestep.quat_from_axis_angle((0, 1, 0), 1e-7)
    assert spherestep.angle_between(ident, tiny) == pytest.approx(1e-7, rel=1e-9)
    # normalised: a scaled quaternion is the same orientation
    assert spherestep.angle_between([0, 0, 0, 5], [2, 0, 0, 0]) == pytest.approx(180, abs=1e-12)
    with pytest.raises(
        spherestep.Error, match=r"argument q2: expected a non-zero, finite quaternion"
    ):
        spherestep.angle_between(ident, [0, 0, 0, 0])
    with pytest.raises(spherestep.Error, match=r"argument q1: expected 4 numbers"):
        spherestep.angle_between([0, 0, 1], ident)


def test_the_helpers_follow_the_plans_conventions(motor):
    # a plan to an orientation made by the helper ends where its summary says, measured by
    # the other helper
    goal = spherestep.quat_from_axis_angle((0, 1, 0), 30)
    plan = motor.plan(to=goal)
    assert spherestep.angle_between(plan.q[-1], goal) == pytest.approx(
        plan.summary["final_orientation_error_deg"], abs=1e-9
    )
    # and a plan of 90 degrees about Z turns row 0 by about 90 degrees
    p = motor.plan(axis=(0, 0, 1), angle=90)
    assert spherestep.angle_between(p.q[0], p.q[-1]) == pytest.approx(p.cum_angle_deg[-1], abs=0.5)
