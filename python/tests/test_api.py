"""The Python API: shapes and types of the results, the same numbers whatever form the
arguments take, determinism on any number of threads, and the GIL released while settling."""

import signal
import threading
import time

import numpy as np
import pytest

import spherestep
from conftest import SCENARIOS


@pytest.fixture(scope="module")
def motor():
    return spherestep.Scenario.prototype().motor()


def test_scenario_packings(prototype_toml):
    sc = spherestep.Scenario.load(prototype_toml)
    assert sc.name == "prototype" and str(sc.path) == str(prototype_toml)
    assert sc.rotor.shape == (80, 3) and sc.stator.shape == (16, 3)
    np.testing.assert_allclose(np.linalg.norm(sc.rotor, axis=1), 1.0, atol=1e-12)
    # the cap is at the bottom, around -Z
    assert (sc.stator[:, 2] < 0).all()
    m = sc.motor()
    assert (m.magnets, m.coils) == (80, 16) and m.scenario.name == "prototype"


def test_settle_one_set(motor):
    r = motor.settle("0:14,12:26")
    assert r.q.shape == (4,) and r.q[3] >= 0
    assert abs(np.linalg.norm(r.q) - 1) < 1e-12
    assert r.settled and r.outcome == "held" and r.stop == "settled"
    assert r.held == [(0, 14), (12, 26)] and r.not_held == []
    assert 0 < r.settle_time_s < 5 and r.evaluations > r.steps > 0
    assert r.residual_torque_nm < 1e-4
    # one pair far out of reach holds nothing: the ball is left where it was
    far = motor.settle([(0, 0)])
    assert far.outcome == "unheld" and far.q.tolist() == [0.0, 0.0, 0.0, 1.0]


def test_pairs_and_orientations_in_any_form_give_the_same_bits(motor):
    q0 = [0.1, -0.2, 0.05, 0.97]
    a = motor.settle("0:14,12:26", q0=q0)
    b = motor.settle([(0, 14), (12, 26)], q0=tuple(q0))
    c = motor.settle(np.array([[0, 14], [12, 26]], dtype=np.int64), q0=np.array(q0))
    d = motor.settle([[0, 14], [12, 26]], q0=[np.float64(x) for x in q0])
    assert a.q.tolist() == b.q.tolist() == c.q.tolist() == d.q.tolist()
    assert a.settle_time_s == b.settle_time_s == c.settle_time_s
    # the start is normalised: a scaled quaternion is the same orientation
    e = motor.settle("0:14,12:26", q0=[2 * x for x in q0])
    assert np.allclose(e.q, a.q, atol=1e-12)


def test_settle_many_is_settle_in_parallel(motor):
    sets = ["0:14,12:26", [(0, 14)], "3:40,9:12,14:2", "5:5"]
    t = motor.settle_many(sets)
    assert len(t) == 4 and t.q.shape == (4, 4)
    assert t.settle_time_s.dtype == np.float64 and t.settled.dtype == np.bool_
    assert t.evaluations.dtype == np.uint32
    for k, s in enumerate(sets):
        r = motor.settle(s)
        assert t.q[k].tolist() == r.q.tolist()
        assert t.evaluations[k] == r.evaluations and t.outcome[k] == r.outcome
        assert t.held[k] == r.held
    assert t.active[2] == [(3, 40), (9, 12), (14, 2)]
    # a numpy integer array of shape (sets, pairs, 2) is sets too
    arr = np.array([[[0, 14], [12, 26]], [[3, 40], [9, 12]]])
    u = motor.settle_many(arr)
    assert u.q[0].tolist() == t.q[0].tolist() and u.active[1] == [(3, 40), (9, 12)]


def test_settle_many_is_the_same_on_any_number_of_threads(motor):
    rng = np.random.default_rng(5)
    sets = [
        [(int(c), int(m)) for c, m in zip(rng.choice(16, 2, replace=False), rng.integers(0, 80, 2))]
        for _ in range(64)
    ]
    one = motor.settle_many(sets, threads=1)
    two = motor.settle_many(sets, threads=2)
    default = motor.settle_many(sets)
    for col in ["q", "settle_time_s", "evaluations", "energy_j", "residual_torque_nm"]:
        np.testing.assert_array_equal(getattr(one, col), getattr(two, col))
        np.testing.assert_array_equal(getattr(one, col), getattr(default, col))


def test_settle_many_columns_are_read_only(motor):
    t = motor.settle_many(["0:14"])
    with pytest.raises(ValueError):
        t.q[0, 0] = 1.0
    assert t.q is t.q  # one array, not a copy per access
    empty = motor.settle_many([])
    assert len(empty) == 0 and empty.q.shape == (0, 4)


def reachable_sets(sc, n, seed):
    """n sets of 2 to 4 coils, each with a magnet within the 30 degree cut-off of it at the
    identity: sets that hold the ball and take a real settle."""
    angle = np.degrees(np.arccos(np.clip(sc.stator @ sc.rotor.T, -1, 1)))
    rng = np.random.default_rng(seed)
    sets = []
    while len(sets) < n:
        coils = rng.choice(len(sc.stator), rng.integers(2, 5), replace=False)
        magnets = [int(rng.choice(np.nonzero(angle[c] < 30)[0])) for c in coils]
        if len(set(magnets)) == len(magnets):
            sets.append(list(zip(map(int, coils), magnets)))
    return sets


def test_settle_many_releases_the_gil():
    sc = spherestep.Scenario.prototype()
    motor = sc.motor()
    # enough sets for the call to take a while on this machine (the settles get faster): the
    # count doubles until one thread takes 0.2 s
    n = 3000
    while True:
        sets = reachable_sets(sc, n, 11)
        start = time.perf_counter()
        motor.settle_many(sets, threads=1)
        alone = time.perf_counter() - start
        if alone > 0.2 or n >= 96000:
            break
        n *= 2
    ticks = []
    worker = threading.Thread(target=motor.settle_many, args=(sets,), kwargs={"threads": 1})
    worker.start()
    while worker.is_alive():
        ticks.append(time.perf_counter())
        time.sleep(0.002)
    worker.join()
    # the settles take a while, and meanwhile this thread ran on: a held GIL would have
    # blocked it from the call's start to its end
    assert alone > 0.1, alone
    assert len(ticks) > 10
    assert max(np.diff(ticks)) < 0.5 * alone


def test_plan_columns_and_summary(motor, tmp_path):
    plan = motor.plan(axis=[0, 0, 1], angle=90)
    n = len(plan)
    assert n >= 2 and plan.q.shape == (n, 4) and plan.step.tolist() == list(range(n))
    assert plan.pivot[0] is None
    # a step keeps a held pair (its pivot) and switches on new ones; landing on the target
    # orientation, it may keep any of the pairs on (or none) and switch new ones on, or only
    # switch some off: every pair on after it was on before or is new
    for k in range(1, n):
        p = plan.pivot[k]
        if p is not None:
            assert p in plan.active[k - 1], k
        assert all(a in plan.active[k - 1] or a in plan.new[k] for a in plan.active[k]), k
    assert any(p is not None for p in plan.pivot[1:])
    assert plan.cum_angle_deg[0] == 0.0 and abs(plan.cum_angle_deg[-1] - 90) < 2
    s = plan.summary
    assert s["steps"] == n - 1 and s["reached"] is plan.reached
    # reached: within the plan's tolerance (1 degree) of the target orientation, and only then
    assert plan.reached == (s["final_orientation_error_deg"] <= s["tolerance_deg"] == 1.0)
    assert s["max_axis_error_deg"] == plan.cum_axis_error_deg.max()
    assert list(s)[:3] == ["steps", "final_angle_deg", "max_axis_error_deg"]
    # the path deviation: the worst row's angle from the slerp from row 0 to the goal (90
    # degrees about Z applied to row 0), here recomputed by sampling that slerp
    assert 0 < s["max_path_deviation_deg"] < 30
    assert abs(s["max_path_deviation_deg"] - _path_deviation_deg(plan.q)) < 0.01
    assert plan.settings["axis"] == [0.0, 0.0, 1.0] and plan.settings["pairs"] == "2-4"
    out = tmp_path / "plan.csv"
    plan.to_csv(out)
    assert out.read_text() == plan.csv()
    assert plan.csv().splitlines()[0].startswith("step,pivot_coil,pivot_magnet,new_coil")


def _path_deviation_deg(q):
    """The worst angle, degrees, from the rows `q` ([qx, qy, qz, qw]) to 2001 points of the
    slerp from row 0 to the turn of 90 degrees about Z applied to it."""
    h = np.sqrt(0.5)
    x0, y0, z0, w0 = q[0]
    # (0, 0, h, h) * q[0], Hamilton product in [x, y, z, w]
    goal = h * np.array([x0 - y0, y0 + x0, z0 + w0, w0 - z0])
    a, b = q[0], goal if np.dot(q[0], goal) >= 0 else -goal
    theta = np.arccos(min(1.0, np.dot(a, b)))
    t = np.linspace(0.0, 1.0, 2001)[:, None]
    path = (np.sin((1 - t) * theta) * a + np.sin(t * theta) * b) / np.sin(theta)
    dots = np.clip(np.abs(q @ path.T).max(axis=1), 0.0, 1.0)
    return float(np.degrees(2 * np.arccos(dots)).max())


def test_plan_defaults_are_the_scenarios():
    sc = spherestep.Scenario.load(SCENARIOS / "paper-fig8-y.toml")
    plan = sc.motor().plan()
    assert plan.settings["axis"] == [0.0, 1.0, 0.0] and plan.settings["angle_deg"] == 90.0
    assert plan.settings["model"] == "pivot" and plan.settings["scheme"] == "search"
    # the paper's pivot plans about Y sit on the pivot model's floor (README: 10.81 degrees)
    assert round(plan.summary["max_axis_error_deg"], 2) == 10.81


def test_simulate_replays_the_plan(motor):
    plan = motor.plan(axis=(1, 0, 0), angle=45)
    sim = motor.simulate(plan)
    assert len(sim) == len(plan) and sim.q.shape == plan.q.shape
    assert sim.step.tolist() == plan.step.tolist()
    assert sim.deviation_deg.max() < 1e-6 and sim.settled.all()
    assert sim.summary["steps"] == len(plan) - 1


def test_wells_curve(motor):
    w = motor.wells()
    assert w.angle_deg[0] == 0.0 and w.torque_nm[0] == 0.0
    assert w.angle_deg[1] == 0.02 and w.angle_deg[-1] == 30.0
    s = w.summary
    assert s["rows"] == len(w) and 0.8 < s["peak_torque_nm"] < 0.9
    assert w.torque_nm.max() == s["peak_torque_nm"]


def test_open_loop_run_on_the_model_itself(motor):
    run = motor.run(axis=(0, 0, 1), angle=60)
    s = run.summary
    assert s["mode"] == "open" and s["replans"] == 0
    assert len(run) == s["planned_steps"] + 1
    # played on the model itself, the ball ends where the plan said
    plan = motor.plan(axis=(0, 0, 1), angle=60)
    assert s["final_error_deg"] == pytest.approx(plan.summary["final_orientation_error_deg"], abs=1e-9)
    assert s["final_angle_deg"] == pytest.approx(plan.summary["final_angle_deg"], abs=1e-9)
    np.testing.assert_allclose(run.true_q, run.planned_q, atol=1e-9)
    assert not run.replanned.any()
    assert run.csv().splitlines()[0].startswith("step,active,replanned,planned_qx")


def test_closed_loop_run_is_deterministic(motor):
    plant = spherestep.Scenario.load(SCENARIOS / "plants" / "prototype-worn.toml").motor()
    a = motor.run(plant, axis=(0, 0, 1), angle=90, closed_loop=True, sensor_noise_deg=1.0, seed=2)
    b = motor.run(plant, axis=(0, 0, 1), angle=90, closed_loop=True, sensor_noise_deg=1.0, seed=2)
    assert a.csv() == b.csv()
    # the ball ends within the 2 degree goal tolerance; the run is reached when its last
    # (noisy) measurement says so too
    assert a.summary["final_error_deg"] < 2.0
    assert a.summary["reached"] == (a.summary["final_measured_error_deg"] <= 2.0)
    np.testing.assert_array_equal(a.measured_q, b.measured_q)


class Interrupted(Exception):
    pass


def interrupted_after(seconds, call):
    """Runs `call` with a signal handler that raises Interrupted after `seconds` (as Ctrl-C
    raises KeyboardInterrupt); returns how long the call took to give up."""

    def handler(signum, frame):
        raise Interrupted()

    old = signal.signal(signal.SIGALRM, handler)
    try:
        signal.setitimer(signal.ITIMER_REAL, seconds)
        start = time.perf_counter()
        with pytest.raises(Interrupted):
            call()
        return time.perf_counter() - start
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def test_ctrl_c_stops_settle_many():
    sc = spherestep.Scenario.prototype()
    motor = sc.motor()
    sets = reachable_sets(sc, 40_000, 3)
    start = time.perf_counter()
    motor.settle_many(sets[:4096])
    full = (time.perf_counter() - start) * len(sets) / 4096
    took = interrupted_after(0.2, lambda: motor.settle_many(sets))
    # it gave up within a chunk or so, long before the whole would have taken
    assert took < 0.5 * full, (took, full)
    # and the motor is none the worse for it
    assert motor.settle_many(sets[:3]).q.tolist() == motor.settle_many(sets[:3]).q.tolist()


def test_ctrl_c_stops_a_long_plan():
    # coil-set plans in broad wells take seconds (about 9 s for this one on two cores)
    motor = spherestep.Scenario.load(SCENARIOS / "soft-wells.toml").motor()
    took = interrupted_after(0.3, lambda: motor.plan(axis=(0, 1, 0), angle=90))
    assert took < 2.0, took
