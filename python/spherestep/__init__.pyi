"""Type stubs of spherestep (the compiled module spherestep._spherestep).

Orientations are unit quaternions [qx, qy, qz, qw] (vector, scalar), body to world; results
write them with qw >= 0. Angles are degrees, other units SI. _Pairs are (coil, magnet), 0-based.
"""

import os
import pathlib
from typing import Any, Literal, Optional, Sequence, Tuple, Union, final, overload

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
    "angle_between",
    "fit",
    "quat_from_axis_angle",
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
#: Orientations for settle_many: one for all the sets, or one per set (a sequence of them, or
#: an array of shape (sets, 4)).
_Starts = Union[_Quaternion, Sequence[_Quaternion], npt.NDArray[np.floating]]

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
        paths (default: no file, errors say "<string>", relative paths from the current
        folder)."""
    @staticmethod
    def prototype() -> Scenario:
        """The built-in prototype with every default, named as scenarios/prototype.toml."""
    def replace(
        self, changes: Optional[dict[str, Any]] = None, /, **kwargs: Any
    ) -> Scenario:
        """A copy with values replaced, checked as a file: keys "section.key" or top-level
        keys, keyword sections as dicts (body={"damping": 0.8}); None restores the default;
        Error naming the key for an unknown key or a value not allowed."""
    def motor(self) -> Motor:
        """The scenario's motor."""
    @property
    def name(self) -> str: ...
    @property
    def description(self) -> str: ...
    @property
    def path(self) -> Optional[pathlib.Path]:
        """The file it was read from (or from_toml's `path`); None for text that names no
        file and for the built-in prototype."""
    @property
    def toml(self) -> str:
        """The TOML text it was made from (with replace's changes)."""
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
        q0: Optional[_Starts] = None,
        threads: Optional[int] = None,
    ) -> SettleTable:
        """Settles each set in parallel (threads: default one per core); the same results, in
        the sets' order, on any number of threads. q0: one start for all the sets (default
        identity), or one per set (as many orientations as sets, or an array of shape
        (sets, 4)): set k from q0[k], as settle(sets[k], q0[k]). Error (a ValueError) naming
        q0 if the number of starts is not the number of sets."""
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
    @overload
    def simulate(
        self,
        plan: Union[Plan, _PathLike],
        plant: Optional[Motor] = None,
        *,
        closed_loop: Literal[False] = False,
        model: None = None,
        sensor_noise_deg: float = 0.0,
        seed: None = None,
        max_steps: None = None,
        identify: bool = True,
    ) -> Simulation:
        """Replays a plan (or a plan file) through the dynamics of this motor or of `plant`
        (a motor with the same packings)."""
    @overload
    def simulate(
        self,
        plan: Union[Plan, _PathLike],
        plant: Optional[Motor] = None,
        *,
        closed_loop: Literal[True],
        model: Optional[str] = None,
        sensor_noise_deg: float = 0.0,
        seed: Optional[int] = None,
        max_steps: Optional[int] = None,
        identify: bool = True,
    ) -> Run:
        """The plan played closed loop on `plant` (default: this motor), replanning in this
        motor's physics: `spherestep simulate PLAN SCENARIO --plant PLANT --closed-loop`."""
    def pairs_within(
        self, reach_deg: Optional[float] = None, q: Optional[_Quaternion] = None
    ) -> list[_Pair]:
        """The (coil, magnet) pairs whose magnet is within reach_deg degrees of its coil at
        orientation q (default identity); reach_deg defaults to the coil's reach."""
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
    active_magnet: npt.NDArray[np.int64]
    """Shape (sets, coils): the magnet each set pairs each coil with, -1 where it leaves the
    coil out."""
    def __len__(self) -> int:
        """The number of sets (rows)."""
    def to_dict(self) -> dict[str, list[Any]]:
        """The columns as {name: list}, one item per row: active, qx, qy, qz, qw, settle_time_s,
        evaluations, steps, energy_j, residual_torque_nm, settled, outcome, held."""
    def to_pandas(self) -> Any:
        """The columns of to_dict as a pandas.DataFrame (numbers keep their dtypes: int64,
        float64, bool). pandas is imported only here; ImportError ("pip install pandas") if it
        is missing."""
    def _repr_html_(self) -> str:
        """An HTML table of the rows (what Jupyter shows), its texts escaped; the repr as its
        caption; more than 60 rows: the first and last 20."""

@final
class Plan:
    """A plan's rows as numpy columns (row 0: the initial commutation state, then one row per
    step: len(plan) is summary["steps"] + 1, as the repr says)."""

    @property
    def step(self) -> npt.NDArray[np.int64]:
        """0 (the initial commutation), 1, 2, ...: signed, so step - 1 is -1 at row 0."""
    @property
    def pivot(self) -> list[Optional[_Pair]]: ...
    @property
    def new(self) -> list[list[_Pair]]: ...
    @property
    def active(self) -> list[list[_Pair]]: ...
    @property
    def pivot_coil(self) -> npt.NDArray[np.int64]:
        """The pivot's coil per row, -1 for none (row 0)."""
    @property
    def pivot_magnet(self) -> npt.NDArray[np.int64]:
        """The pivot's magnet per row, -1 for none (row 0)."""
    @property
    def new_magnet(self) -> npt.NDArray[np.int64]:
        """Shape (rows, coils): the magnet each step pairs each coil with, -1 for none."""
    @property
    def active_magnet(self) -> npt.NDArray[np.int64]:
        """Shape (rows, coils): the magnet each coil pulls after each step, -1 when off."""
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
    def __len__(self) -> int:
        """The number of rows: the steps and row 0, the initial commutation."""
    def to_dict(self) -> dict[str, list[Any]]:
        """The columns as {name: list}, one item per row: step, pivot, new, active, qx, qy, qz,
        qw, step_angle_deg, step_axis_error_deg, cum_angle_deg, cum_axis_error_deg,
        settle_time_s, settled."""
    def to_pandas(self) -> Any:
        """The columns of to_dict as a pandas.DataFrame (numbers keep their dtypes: int64,
        float64, bool). pandas is imported only here; ImportError ("pip install pandas") if it
        is missing."""
    def _repr_html_(self) -> str:
        """An HTML table of the rows (what Jupyter shows), its texts escaped; the repr as its
        caption; more than 60 rows: the first and last 20."""

@final
class Simulation:
    """A plan replayed through the dynamics, one row per plan row."""

    @property
    def step(self) -> npt.NDArray[np.int64]:
        """The plan's step numbers (signed)."""
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
    def __len__(self) -> int:
        """The number of rows: the steps and row 0, the initial commutation."""
    def to_dict(self) -> dict[str, list[Any]]:
        """The columns as {name: list}, one item per row: step, qx, qy, qz, qw, deviation_deg,
        settled, settle_time_s."""
    def to_pandas(self) -> Any:
        """The columns of to_dict as a pandas.DataFrame (numbers keep their dtypes: int64,
        float64, bool). pandas is imported only here; ImportError ("pip install pandas") if it
        is missing."""
    def _repr_html_(self) -> str:
        """An HTML table of the rows (what Jupyter shows), its texts escaped; the repr as its
        caption; more than 60 rows: the first and last 20."""

@final
class Wells:
    @property
    def angle_deg(self) -> npt.NDArray[np.float64]: ...
    @property
    def torque_nm(self) -> npt.NDArray[np.float64]: ...
    @property
    def summary(self) -> dict[str, Any]: ...
    def csv(self) -> str: ...
    def __len__(self) -> int:
        """The number of angles (rows)."""
    def to_dict(self) -> dict[str, list[Any]]:
        """The columns as {name: list}, one item per row: angle_deg, torque_nm."""
    def to_pandas(self) -> Any:
        """The columns of to_dict as a pandas.DataFrame (numbers keep their dtypes: int64,
        float64, bool). pandas is imported only here; ImportError ("pip install pandas") if it
        is missing."""
    def _repr_html_(self) -> str:
        """An HTML table of the rows (what Jupyter shows), its texts escaped; the repr as its
        caption; more than 60 rows: the first and last 20."""

@final
class Run:
    @property
    def step(self) -> npt.NDArray[np.int64]:
        """The step numbers, 0 the initial commutation state (signed)."""
    @property
    def active(self) -> list[list[_Pair]]: ...
    @property
    def active_magnet(self) -> npt.NDArray[np.int64]:
        """Shape (rows, coils): the magnet each coil pulled at each step, -1 when off."""
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
    def __len__(self) -> int:
        """The number of rows: the steps played and row 0, the initial commutation."""
    def to_dict(self) -> dict[str, list[Any]]:
        """The columns as {name: list}, one item per row: step, active, replanned, planned_qx,
        planned_qy, planned_qz, planned_qw, measured_qx .. measured_qw, true_qx .. true_qw,
        cum_angle_deg, cum_axis_error_deg, error_to_goal_deg, settled, settle_time_s."""
    def to_pandas(self) -> Any:
        """The columns of to_dict as a pandas.DataFrame (numbers keep their dtypes: int64,
        float64, bool). pandas is imported only here; ImportError ("pip install pandas") if it
        is missing."""
    def _repr_html_(self) -> str:
        """An HTML table of the rows (what Jupyter shows), its texts escaped; the repr as its
        caption; more than 60 rows: the first and last 20."""

def quat_from_axis_angle(axis: _Vector, angle_deg: float) -> Tuple[float, float, float, float]:
    """The orientation reached by turning angle_deg degrees about axis (x, y, z, any non-zero
    length; right-handed) from the identity, as (qx, qy, qz, qw) with qw >= 0 like every
    orientation the package returns (a turn of more than 180 degrees gives the same
    orientation as the shorter turn the other way). Error (a ValueError) for a zero or
    non-finite axis or angle."""

def angle_between(q1: _Quaternion, q2: _Quaternion) -> float:
    """The angle between two orientations [qx, qy, qz, qw] (normalised here), degrees in
    [0, 180]: the rotation angle of the turn from one to the other (q and -q are the same
    orientation). Error (a ValueError) for a zero or non-finite quaternion."""

def fit(
    scenario: Union[Scenario, _PathLike],
    torque: Optional[_PathLike] = None,
    log: Optional[_PathLike] = None,
    *,
    holdout: int = 0,
    fit_as: Optional[Literal["wells", "gaussian", "cosine", "physical"]] = None,
) -> dict[str, Any]:
    """Fits scenario (a Scenario or a scenario file's path) to a bench's torque curve torque
    (a CSV of angle_deg,torque_nm) and/or a closed-loop replay's log (replay --sensor --log;
    its last holdout steps predicted, not fitted), as `spherestep fit` does: a physical
    scenario (shape = "dipole") fits its core_gain and gap_m (fit_as="physical", its
    default), any other its wells ("wells": gaussian and cosine, the better chosen; or
    "gaussian", "cosine"). Returns a dict: fitted_as; parameters (each fitted [magnets] key
    and its value); std_errors (the same keys, None where the data do not determine it);
    rms_nm (the curve's RMS residual, N m; None without a curve); report (the keys of
    `spherestep fit --json`). Error (a ValueError) naming the file that cannot be read or
    fitted, or the argument not allowed."""
