"""Type stubs of spherestep (the compiled module spherestep._spherestep).

Orientations are unit quaternions [qx, qy, qz, qw] (vector, scalar), body to world; results
write them with qw >= 0. Angles are degrees, other units SI. _Pairs are (coil, magnet), 0-based.
"""

import os
import pathlib
from typing import Any, Optional, Sequence, Tuple, Union, final

import numpy as np
import numpy.typing as npt

__version__: str
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
]

_Pair = Tuple[int, int]
#: An active set: text "coil:magnet,coil:magnet" or a sequence of (coil, magnet) pairs
#: (lists, tuples, an integer array of shape (n, 2)).
_Pairs = Union[str, Sequence[Sequence[int]], npt.NDArray[np.integer]]
#: Four numbers qx, qy, qz, qw: a sequence or an array of shape (4,).
_Quaternion = Union[Sequence[float], npt.NDArray[np.floating]]
#: Three numbers x, y, z: a sequence or an array of shape (3,).
_Vector = Union[Sequence[float], npt.NDArray[np.floating]]
_PathLike = Union[str, os.PathLike[str]]

class Error(ValueError):
    """An error of spherestep, with the library's message (file, field or argument, and what
    was expected)."""

@final
class Scenario:
    """A checked scenario: the motor, body, settle settings and [plan] defaults."""

    @staticmethod
    def load(path: _PathLike) -> Scenario:
        """Reads and checks a scenario file (TOML); Error if it cannot be read or is wrong."""
    @staticmethod
    def from_toml(text: str, path: Optional[_PathLike] = None) -> Scenario:
        """Parses and checks scenario text; `path` names it in errors and anchors relative
        paths (default "<string>", in the current folder)."""
    @staticmethod
    def prototype() -> Scenario:
        """The built-in prototype with every default."""
    def motor(self) -> Motor:
        """The scenario's motor."""
    @property
    def name(self) -> str: ...
    @property
    def description(self) -> str: ...
    @property
    def path(self) -> pathlib.Path:
        """The file it was read from (`<built-in prototype>` for the prototype)."""
    @property
    def rotor(self) -> npt.NDArray[np.float64]:
        """The magnets' unit vectors (body frame), shape (magnets, 3)."""
    @property
    def stator(self) -> npt.NDArray[np.float64]:
        """The coils' unit vectors (world frame), shape (coils, 3)."""

@final
class Motor:
    """A scenario's motor; its methods release the GIL while they compute."""

    @property
    def magnets(self) -> int: ...
    @property
    def coils(self) -> int: ...
    @property
    def scenario(self) -> Scenario: ...
    def settle(self, pairs: _Pairs, q0: Optional[_Quaternion] = None) -> SettleResult:
        """Settles the ball from rest at q0 (default identity) under one active set."""
    def settle_many(
        self,
        sets: Sequence[_Pairs],
        q0: Optional[_Quaternion] = None,
        threads: Optional[int] = None,
    ) -> SettleTable:
        """Settles each set from q0 in parallel (threads: default one per core); the same
        results, in the sets' order, on any number of threads."""
    def plan(
        self,
        axis: Optional[_Vector] = None,
        angle: Optional[float] = None,
        *,
        scheme: Optional[str] = None,
        model: Optional[str] = None,
        pairs: Optional[Union[int, str]] = None,
        start: Optional[_Quaternion] = None,
        to: Optional[_Quaternion] = None,
    ) -> Plan:
        """Plans `angle` degrees about `axis`; every argument left out is the scenario's
        [plan] setting. scheme: min-axis-error, max-angle, weighted or search; model: pivot,
        dynamic or coils; pairs: K or "2-K"; to: a target orientation instead of axis and
        angle."""
    def simulate(
        self, plan: Union[Plan, _PathLike], plant: Optional[Motor] = None
    ) -> Simulation:
        """Replays a plan (or a plan file) through the dynamics of this motor or of `plant`
        (a motor with the same packings)."""
    def wells(self, step_deg: Optional[float] = None) -> Wells:
        """The well's torque curve every step_deg degrees (default 0.02, the command line's)
        from 0 to the cut-off."""
    def run(
        self,
        plant: Optional[Motor] = None,
        axis: Optional[_Vector] = None,
        angle: Optional[float] = None,
        *,
        scheme: Optional[str] = None,
        model: Optional[str] = None,
        pairs: Optional[Union[int, str]] = None,
        start: Optional[_Quaternion] = None,
        to: Optional[_Quaternion] = None,
        closed_loop: bool = False,
        sensor_noise_deg: float = 0.0,
        seed: Optional[int] = None,
        max_steps: Optional[int] = None,
        identify: bool = True,
    ) -> Run:
        """Plans in this motor's physics and plays the plan on `plant` (default: this
        motor), open loop or closed loop on a simulated, seeded sensor (`spherestep run`)."""

@final
class SettleResult:
    @property
    def q(self) -> npt.NDArray[np.float64]:
        """[qx, qy, qz, qw], shape (4,)."""
    @property
    def settle_time_s(self) -> float: ...
    @property
    def arrival_time_s(self) -> float:
        """From when the ball stays within settle.arrival_deg of its rest, s."""
    @property
    def evaluations(self) -> int: ...
    @property
    def steps(self) -> int: ...
    @property
    def energy_j(self) -> float: ...
    @property
    def residual_torque_nm(self) -> float: ...
    @property
    def settled(self) -> bool: ...
    @property
    def stop(self) -> str: ...
    @property
    def active(self) -> list[_Pair]: ...
    @property
    def held(self) -> list[_Pair]: ...
    @property
    def not_held(self) -> list[_Pair]: ...
    @property
    def outcome(self) -> str:
        """held, partly held, unheld or not settled."""

@final
class SettleTable:
    """Many settles as read-only numpy columns, one row per set."""

    q: npt.NDArray[np.float64]
    settle_time_s: npt.NDArray[np.float64]
    evaluations: npt.NDArray[np.uint32]
    steps: npt.NDArray[np.uint32]
    energy_j: npt.NDArray[np.float64]
    residual_torque_nm: npt.NDArray[np.float64]
    settled: npt.NDArray[np.bool_]
    outcome: list[str]
    held: list[list[_Pair]]
    active: list[list[_Pair]]
    def __len__(self) -> int: ...

@final
class Plan:
    """A plan's rows as numpy columns (row 0: the initial commutation state)."""

    @property
    def step(self) -> npt.NDArray[np.uint64]: ...
    @property
    def pivot(self) -> list[Optional[_Pair]]: ...
    @property
    def new(self) -> list[list[_Pair]]: ...
    @property
    def active(self) -> list[list[_Pair]]: ...
    @property
    def q(self) -> npt.NDArray[np.float64]:
        """Shape (rows, 4)."""
    @property
    def step_angle_deg(self) -> npt.NDArray[np.float64]: ...
    @property
    def step_axis_error_deg(self) -> npt.NDArray[np.float64]: ...
    @property
    def cum_angle_deg(self) -> npt.NDArray[np.float64]: ...
    @property
    def cum_axis_error_deg(self) -> npt.NDArray[np.float64]: ...
    @property
    def settle_time_s(self) -> npt.NDArray[np.float64]: ...
    @property
    def settled(self) -> npt.NDArray[np.bool_]: ...
    @property
    def reached(self) -> bool: ...
    @property
    def message(self) -> Optional[str]: ...
    @property
    def summary(self) -> dict[str, Any]:
        """The keys of `spherestep plan --json` (`max_path_deviation_deg` among them)."""
    @property
    def settings(self) -> dict[str, Any]: ...
    def csv(self) -> str:
        """The plan CSV, byte for byte what `spherestep plan --out` writes."""
    def to_csv(self, path: _PathLike) -> None: ...
    def __len__(self) -> int: ...

@final
class Simulation:
    @property
    def step(self) -> npt.NDArray[np.uint64]: ...
    @property
    def q(self) -> npt.NDArray[np.float64]: ...
    @property
    def deviation_deg(self) -> npt.NDArray[np.float64]: ...
    @property
    def settled(self) -> npt.NDArray[np.bool_]: ...
    @property
    def settle_time_s(self) -> npt.NDArray[np.float64]: ...
    @property
    def summary(self) -> dict[str, Any]: ...
    def csv(self) -> str: ...
    def __len__(self) -> int: ...

@final
class Wells:
    @property
    def angle_deg(self) -> npt.NDArray[np.float64]: ...
    @property
    def torque_nm(self) -> npt.NDArray[np.float64]: ...
    @property
    def summary(self) -> dict[str, Any]: ...
    def csv(self) -> str: ...
    def __len__(self) -> int: ...

@final
class Run:
    @property
    def step(self) -> npt.NDArray[np.uint64]: ...
    @property
    def active(self) -> list[list[_Pair]]: ...
    @property
    def replanned(self) -> npt.NDArray[np.bool_]: ...
    @property
    def planned_q(self) -> npt.NDArray[np.float64]: ...
    @property
    def measured_q(self) -> npt.NDArray[np.float64]: ...
    @property
    def true_q(self) -> npt.NDArray[np.float64]: ...
    @property
    def cum_angle_deg(self) -> npt.NDArray[np.float64]: ...
    @property
    def cum_axis_error_deg(self) -> npt.NDArray[np.float64]: ...
    @property
    def error_to_goal_deg(self) -> npt.NDArray[np.float64]: ...
    @property
    def settled(self) -> npt.NDArray[np.bool_]: ...
    @property
    def settle_time_s(self) -> npt.NDArray[np.float64]: ...
    @property
    def summary(self) -> dict[str, Any]:
        """The keys of `spherestep run --json`."""
    def csv(self) -> str: ...
    def __len__(self) -> int: ...
