"""spherestep: spherical stepper motors from Python, at Rust speed.

A ball rotor carrying permanent magnets, turned by switching the electromagnets of a stator cap
(Stein & Chirikjian, DETC2000/MECH-14115). The classes are the Rust library's own:

    import spherestep
    motor = spherestep.Scenario.load("scenarios/prototype.toml").motor()
    r = motor.settle("0:14,12:26")            # one active set of coil:magnet pairs
    table = motor.settle_many(sets)           # many, in parallel, as numpy columns
    plan = motor.plan(axis=(0, 1, 0), angle=90)
    plan.cum_axis_error_deg, plan.summary, plan.to_csv("plan.csv")
    sim = motor.simulate(plan)
    plan.to_pandas()                          # or to_dict(); a notebook shows plan as a table
    q = spherestep.quat_from_axis_angle((0, 0, 1), 30)
    spherestep.angle_between(plan.q[0], plan.q[-1])
    spherestep.fit("scenarios/prototype-physical.toml", torque="bench.csv")["parameters"]

Conventions (frames, quaternions [qx, qy, qz, qw] body to world, degrees, SI units): the
repository's docs/model.md; this package: docs/python.md. Every error is a
``spherestep.Error`` (a ``ValueError``) with the library's message.
"""

from ._spherestep import (
    Error,
    Motor,
    Plan,
    Run,
    Scenario,
    SettleResult,
    SettleTable,
    Simulation,
    Wells,
    angle_between,
    fit,
    quat_from_axis_angle,
)

__all__ = [
    "Error",
    "Motor",
    "Plan",
    "Run",
    "Scenario",
    "SettleResult",
    "SettleTable",
    "Simulation",
    "Wells",
    "angle_between",
    "fit",
    "quat_from_axis_angle",
]
__version__ = "0.1.0"
