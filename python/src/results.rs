//! The results as Python sees them: a settle, many settles as columns, a plan, a replay, a
//! well curve and a run, each with numpy columns, its summary as a dict (the keys of the
//! command line's `--json`) and its CSV (the command line's bytes).

use crate::convert::{column, pair_tuples, q_array, q_rows, summary_dict};
use crate::lib_err;
use crate::table::{self, push_q, Columns};
use numpy::prelude::*;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use pyo3::IntoPyObjectExt;
use spherestep::io::loopfile::write_loop;
use spherestep::io::output::{check_not_input, write_atomic};
use spherestep::io::planfile::write_plan;
use spherestep::io::simfile::write_sim;
use spherestep::io::table::csv_bytes;
use spherestep::planning::holding::Holding;
use spherestep::planning::options::RunSummary;
use spherestep::planning::simulate::summary as sim_summary;
use spherestep::{LoopRun, Pair, PlanSettings, SimRow, WellSummary};
use std::path::PathBuf;
use std::sync::Arc;

/// Sets of pairs as a numpy array of shape `(sets, coils)` (`int64`): row k, column c the
/// magnet set k pairs coil c with, -1 where set k leaves coil c out (a set has each coil once).
fn magnet_per_coil<'py, 'a>(
    py: Python<'py>,
    sets: impl ExactSizeIterator<Item = &'a [Pair]>,
    coils: usize,
) -> PyResult<Bound<'py, PyArray2<i64>>> {
    let n = sets.len();
    let mut flat = vec![-1i64; n * coils];
    for (k, set) in sets.enumerate() {
        for p in set {
            if let Some(cell) = flat.get_mut(k * coils + p.coil.0) {
                *cell = p.magnet.0 as i64;
            }
        }
    }
    PyArray1::from_vec(py, flat).reshape([n, coils])
}

/// Unit vectors as a numpy array of shape `(n, 3)`.
pub fn vectors<'py>(
    py: Python<'py>,
    v: impl ExactSizeIterator<Item = nalgebra::Vector3<f64>>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let n = v.len();
    let flat: Vec<f64> = v.flat_map(|p| [p.x, p.y, p.z]).collect();
    PyArray1::from_vec(py, flat).reshape([n, 3])
}

/// CSV bytes as text (the library writes UTF-8).
fn text(bytes: Vec<u8>) -> String {
    String::from_utf8_lossy(&bytes).into_owned()
}

/// Writes `bytes` to `path` atomically, refusing to overwrite one of the scenario's own files.
fn write_out(sc: &spherestep::Scenario, path: PathBuf, bytes: &[u8]) -> PyResult<()> {
    check_not_input(&path, &sc.files).map_err(lib_err)?;
    write_atomic(&path, bytes).map_err(lib_err)
}

/// How many steps and rows a result of `rows` rows has, as its repr says it: row 0 is the
/// initial commutation state, so the steps are one fewer (`len()` is the rows).
pub fn steps_and_rows(rows: usize) -> String {
    let steps = rows.saturating_sub(1);
    let s = if steps == 1 { "step" } else { "steps" };
    match rows {
        0 => format!("{steps} {s} (no rows)"),
        1 => format!("{steps} {s} (1 row, row 0 the initial commutation)"),
        n => format!("{steps} {s} ({n} rows, row 0 the initial commutation)"),
    }
}

/// Makes a numpy array read-only (a result's columns are what was computed).
fn frozen<'py, T>(a: Bound<'py, T>) -> PyResult<Py<T>> {
    a.as_any().getattr("flags")?.setattr("writeable", false)?;
    Ok(a.unbind())
}

/// One settle: where the ball came to rest, when, and which pairs hold it.
#[pyclass(frozen, module = "spherestep")]
pub struct SettleResult {
    r: spherestep::SettleResult,
    active: Vec<Pair>,
    holding: Holding,
}

impl SettleResult {
    pub fn new(sc: &spherestep::Scenario, active: Vec<Pair>, r: spherestep::SettleResult) -> Self {
        let holding = Holding::of(&sc.torques, &active, &r.q);
        SettleResult { r, active, holding }
    }
}

#[pymethods]
impl SettleResult {
    /// The final orientation `[qx, qy, qz, qw]` (qw >= 0), body to world.
    #[getter]
    fn q<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        q_array(py, &self.r.q)
    }
    /// The simulated time at which the ball settled (or t_max), s.
    #[getter]
    fn settle_time_s(&self) -> f64 {
        self.r.settle_time_s
    }
    /// The simulated time from which the ball stays within the scenario's
    /// `settle.arrival_deg` of where it settles (at most `settle_time_s`), s: what a step's
    /// dwell waits for.
    #[getter]
    fn arrival_time_s(&self) -> f64 {
        self.r.arrival_time_s
    }
    /// Right-hand-side evaluations of the integrator.
    #[getter]
    fn evaluations(&self) -> u32 {
        self.r.evaluations
    }
    /// Accepted integrator steps.
    #[getter]
    fn steps(&self) -> u32 {
        self.r.steps
    }
    /// The potential energy at the end, J.
    #[getter]
    fn energy_j(&self) -> f64 {
        self.r.energy_j
    }
    /// |N_B| at the end, N m.
    #[getter]
    fn residual_torque_nm(&self) -> f64 {
        self.r.residual_torque_nm
    }
    /// Whether the settle test passed before t_max.
    #[getter]
    fn settled(&self) -> bool {
        self.r.settled
    }
    /// Why the settle ended: `settled`, `not settled by t_max`, ...
    #[getter]
    fn stop(&self) -> &'static str {
        self.r.stop.describe()
    }
    /// The active set settled, as `(coil, magnet)` pairs.
    #[getter]
    fn active(&self) -> Vec<(usize, usize)> {
        pair_tuples(&self.active)
    }
    /// The pairs whose magnet ends within its coil's reach.
    #[getter]
    fn held(&self) -> Vec<(usize, usize)> {
        pair_tuples(&self.holding.held)
    }
    /// The pairs whose magnet ends out of its coil's reach.
    #[getter]
    fn not_held(&self) -> Vec<(usize, usize)> {
        pair_tuples(&self.holding.not_held)
    }
    /// `held`, `partly held`, `unheld` (settled, no pair holding) or `not settled`.
    #[getter]
    fn outcome(&self) -> &'static str {
        self.holding.outcome(self.r.settled)
    }
    fn __repr__(&self) -> String {
        let q = spherestep::model::geometry::xyzw(&self.r.q);
        format!(
            "SettleResult(q=[{}, {}, {}, {}], settle_time_s={}, outcome={:?})",
            q[0],
            q[1],
            q[2],
            q[3],
            self.r.settle_time_s,
            self.outcome()
        )
    }
}

/// Many settles as columns: numpy arrays (read-only) with one row per set, in the sets' order.
#[pyclass(frozen, module = "spherestep")]
pub struct SettleTable {
    n: usize,
    /// `(n, 4)`: `[qx, qy, qz, qw]` per set.
    #[pyo3(get)]
    q: Py<PyArray2<f64>>,
    /// Settle times, s.
    #[pyo3(get)]
    settle_time_s: Py<PyArray1<f64>>,
    /// Right-hand-side evaluations.
    #[pyo3(get)]
    evaluations: Py<PyArray1<u32>>,
    /// Accepted integrator steps.
    #[pyo3(get)]
    steps: Py<PyArray1<u32>>,
    /// Potential energies at the end, J.
    #[pyo3(get)]
    energy_j: Py<PyArray1<f64>>,
    /// |N_B| at the end, N m.
    #[pyo3(get)]
    residual_torque_nm: Py<PyArray1<f64>>,
    /// Whether each settled before t_max.
    #[pyo3(get)]
    settled: Py<PyArray1<bool>>,
    /// `held`, `partly held`, `unheld` or `not settled`, per set.
    #[pyo3(get)]
    outcome: Vec<&'static str>,
    /// The pairs holding the ball at the end, per set.
    #[pyo3(get)]
    held: Vec<Vec<(usize, usize)>>,
    /// The sets, as `(coil, magnet)` pairs.
    #[pyo3(get)]
    active: Vec<Vec<(usize, usize)>>,
    /// The sets as indices, shape `(n, coils)` (`int64`): row k, column c the magnet set k
    /// pairs coil c with, -1 where set k leaves coil c out.
    #[pyo3(get)]
    active_magnet: Py<PyArray2<i64>>,
}

impl SettleTable {
    pub fn new(
        py: Python<'_>,
        sets: Vec<Vec<Pair>>,
        rs: Vec<spherestep::SettleResult>,
        holding: Vec<Holding>,
        coils: usize,
    ) -> PyResult<SettleTable> {
        let col = |f: &dyn Fn(&spherestep::SettleResult) -> f64| -> PyResult<Py<PyArray1<f64>>> {
            frozen(column(py, rs.iter().map(f).collect()))
        };
        Ok(SettleTable {
            n: rs.len(),
            q: frozen(q_rows(py, rs.iter().map(|r| &r.q))?)?,
            settle_time_s: col(&|r| r.settle_time_s)?,
            evaluations: frozen(column(py, rs.iter().map(|r| r.evaluations).collect()))?,
            steps: frozen(column(py, rs.iter().map(|r| r.steps).collect()))?,
            energy_j: col(&|r| r.energy_j)?,
            residual_torque_nm: col(&|r| r.residual_torque_nm)?,
            settled: frozen(column(py, rs.iter().map(|r| r.settled).collect()))?,
            outcome: rs
                .iter()
                .zip(&holding)
                .map(|(r, h)| h.outcome(r.settled))
                .collect(),
            held: holding.iter().map(|h| pair_tuples(&h.held)).collect(),
            active: sets.iter().map(|s| pair_tuples(s)).collect(),
            active_magnet: frozen(magnet_per_coil(py, sets.iter().map(|s| &s[..]), coils)?)?,
        })
    }
}

impl SettleTable {
    fn columns<'py>(&self, py: Python<'py>) -> PyResult<Columns<'py>> {
        let mut c: Columns<'py> =
            vec![("active".into(), self.active.clone().into_bound_py_any(py)?)];
        push_q(&mut c, "", self.q.bind(py).as_any())?;
        c.push((
            "settle_time_s".into(),
            self.settle_time_s.bind(py).clone().into_any(),
        ));
        c.push((
            "evaluations".into(),
            self.evaluations.bind(py).clone().into_any(),
        ));
        c.push(("steps".into(), self.steps.bind(py).clone().into_any()));
        c.push(("energy_j".into(), self.energy_j.bind(py).clone().into_any()));
        c.push((
            "residual_torque_nm".into(),
            self.residual_torque_nm.bind(py).clone().into_any(),
        ));
        c.push(("settled".into(), self.settled.bind(py).clone().into_any()));
        c.push((
            "outcome".into(),
            self.outcome.clone().into_bound_py_any(py)?,
        ));
        c.push(("held".into(), self.held.clone().into_bound_py_any(py)?));
        Ok(c)
    }
}

#[pymethods]
impl SettleTable {
    fn __len__(&self) -> usize {
        self.n
    }
    fn __repr__(&self) -> String {
        format!("SettleTable({} sets)", self.n)
    }
    /// The columns as a dict of lists, one row per set: `active`, `qx`, `qy`, `qz`, `qw`,
    /// `settle_time_s`, `evaluations`, `steps`, `energy_j`, `residual_torque_nm`, `settled`,
    /// `outcome`, `held`.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        table::to_dict(py, &self.columns(py)?)
    }
    /// The columns of `to_dict` as a pandas DataFrame (ImportError without pandas).
    fn to_pandas<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        table::to_pandas(py, "SettleTable", &self.columns(py)?)
    }
    fn _repr_html_(&self, py: Python<'_>) -> PyResult<String> {
        table::to_html(&self.__repr__(), &self.columns(py)?)
    }
}

/// A plan: the sequence of commutation steps (row 0 the initial commutation state), its
/// columns as numpy arrays, and its summary.
#[pyclass(frozen, module = "spherestep")]
pub struct Plan {
    pub(crate) plan: spherestep::Plan,
    pub(crate) settings: PlanSettings,
    pub(crate) sc: Arc<spherestep::Scenario>,
}

impl Plan {
    fn columns<'py>(&self, py: Python<'py>) -> PyResult<Columns<'py>> {
        let mut c: Columns<'py> = vec![
            ("step".into(), self.step(py).into_any()),
            ("pivot".into(), self.pivot().into_bound_py_any(py)?),
            ("new".into(), self.new_pairs().into_bound_py_any(py)?),
            ("active".into(), self.active().into_bound_py_any(py)?),
        ];
        push_q(&mut c, "", self.q(py)?.as_any())?;
        for (name, f) in [
            (
                "step_angle_deg",
                Plan::step_angle_deg as fn(&Plan, Python<'py>) -> _,
            ),
            ("step_axis_error_deg", Plan::step_axis_error_deg),
            ("cum_angle_deg", Plan::cum_angle_deg),
            ("cum_axis_error_deg", Plan::cum_axis_error_deg),
            ("settle_time_s", Plan::settle_time_s),
        ] {
            c.push((name.into(), f(self, py).into_any()));
        }
        c.push(("settled".into(), self.settled(py).into_any()));
        Ok(c)
    }

    fn numbers<'py>(
        &self,
        py: Python<'py>,
        f: fn(&spherestep::PlanRow) -> f64,
    ) -> Bound<'py, PyArray1<f64>> {
        column(py, self.plan.rows.iter().map(f).collect())
    }
}

#[pymethods]
impl Plan {
    /// The step numbers: 0 (the initial commutation), 1, 2, ...
    #[getter]
    fn step<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        column(py, self.plan.rows.iter().map(|r| r.step as i64).collect())
    }
    /// The pair held through each step, `(coil, magnet)` (None for step 0).
    #[getter]
    fn pivot(&self) -> Vec<Option<(usize, usize)>> {
        self.plan
            .rows
            .iter()
            .map(|r| r.pivot.map(|p| (p.coil.0, p.magnet.0)))
            .collect()
    }
    /// The pairs each step switches on.
    #[getter(new)]
    fn new_pairs(&self) -> Vec<Vec<(usize, usize)>> {
        self.plan.rows.iter().map(|r| pair_tuples(&r.new)).collect()
    }
    /// Everything energised after each step.
    #[getter]
    fn active(&self) -> Vec<Vec<(usize, usize)>> {
        self.plan
            .rows
            .iter()
            .map(|r| pair_tuples(&r.active))
            .collect()
    }
    /// The pivot's coil for each row as a signed index (`int64`), -1 for none (row 0): the
    /// plan CSV's `pivot_coil`.
    #[getter]
    fn pivot_coil<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        let c = |r: &spherestep::PlanRow| r.pivot.map_or(-1, |p| p.coil.0 as i64);
        column(py, self.plan.rows.iter().map(c).collect())
    }
    /// The pivot's magnet for each row as a signed index (`int64`), -1 for none (row 0): the
    /// plan CSV's `pivot_magnet`.
    #[getter]
    fn pivot_magnet<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        let m = |r: &spherestep::PlanRow| r.pivot.map_or(-1, |p| p.magnet.0 as i64);
        column(py, self.plan.rows.iter().map(m).collect())
    }
    /// The pairs each step switches on as indices, shape `(rows, coils)` (`int64`): row k,
    /// column c is the magnet step k pairs coil c with, -1 where step k switches no pair of
    /// coil c on.
    #[getter]
    fn new_magnet<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        magnet_per_coil(
            py,
            self.plan.rows.iter().map(|r| &r.new[..]),
            self.sc.stator.len(),
        )
    }
    /// Everything energised after each step as indices, shape `(rows, coils)` (`int64`): row
    /// k, column c is the magnet coil c pulls after step k, -1 where coil c is off.
    #[getter]
    fn active_magnet<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        magnet_per_coil(
            py,
            self.plan.rows.iter().map(|r| &r.active[..]),
            self.sc.stator.len(),
        )
    }
    /// The predicted orientation after each step, shape `(rows, 4)`: `[qx, qy, qz, qw]`.
    #[getter]
    fn q<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        q_rows(py, self.plan.rows.iter().map(|r| &r.q))
    }
    /// Each step's rotation angle about the target axis, degrees (signed).
    #[getter]
    fn step_angle_deg<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.numbers(py, |r| r.step_angle_deg)
    }
    /// The angle between each step's rotation axis and the target axis, degrees.
    #[getter]
    fn step_axis_error_deg<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.numbers(py, |r| r.step_axis_error_deg)
    }
    /// The cumulative rotation's angle about the target axis from row 0, degrees.
    #[getter]
    fn cum_angle_deg<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.numbers(py, |r| r.cum_angle_deg)
    }
    /// The cumulative rotation's axis error from row 0, degrees (the paper's Figures 7, 8).
    #[getter]
    fn cum_axis_error_deg<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.numbers(py, |r| r.cum_axis_error_deg)
    }
    /// Each step's predicted settle time, s: until the ball stays within the scenario's
    /// `settle.arrival_deg` of its rest (t_max where it does not settle).
    #[getter]
    fn settle_time_s<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.numbers(py, |r| r.settle_time_s)
    }
    /// Whether each step settles in the dynamics within t_max.
    #[getter]
    fn settled<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        column(py, self.plan.rows.iter().map(|r| r.settled).collect())
    }
    /// Whether the plan ends within its tolerance (`plan.tolerance_deg`, 1 degree) of the target
    /// orientation.
    #[getter]
    fn reached(&self) -> bool {
        self.plan.reached
    }
    /// Why the plan stopped short, when it did.
    #[getter]
    fn message(&self) -> Option<String> {
        self.plan.message.clone()
    }
    /// The summary, with the keys of `spherestep plan --json`.
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        summary_dict(py, &self.plan.summary(&self.settings))
    }
    /// What was planned: the target axis (world frame) and angle (degrees), the scheme, the
    /// step model and the pairs per step.
    #[getter]
    fn settings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = &self.settings;
        let d = PyDict::new(py);
        d.set_item("axis", [s.axis.x, s.axis.y, s.axis.z].to_vec())?;
        d.set_item("angle_deg", s.angle.0.to_degrees())?;
        d.set_item("scheme", s.scheme.name())?;
        d.set_item("model", s.model.name())?;
        d.set_item("pairs", s.pairs.to_string())?;
        d.set_item("start", q_array(py, &s.start))?;
        Ok(d)
    }
    /// The plan as CSV text: what `spherestep plan --out` writes, byte for byte.
    fn csv(&self) -> PyResult<String> {
        let mut buf = Vec::new();
        write_plan(&self.plan.rows, &mut buf).map_err(lib_err)?;
        Ok(text(buf))
    }
    /// Writes the plan CSV to `path` (atomically; never over one of the scenario's files), for
    /// `spherestep simulate`, `replay` and `view`.
    fn to_csv(&self, path: PathBuf) -> PyResult<()> {
        let mut buf = Vec::new();
        write_plan(&self.plan.rows, &mut buf).map_err(lib_err)?;
        write_out(&self.sc, path, &buf)
    }
    /// The rows: row 0 the initial commutation state, then one per step (`summary["steps"]`
    /// is one fewer).
    fn __len__(&self) -> usize {
        self.plan.rows.len()
    }
    /// The columns as a dict of lists, one per row: `step`, `pivot`, `new`, `active`, `qx`,
    /// `qy`, `qz`, `qw`, `step_angle_deg`, `step_axis_error_deg`, `cum_angle_deg`,
    /// `cum_axis_error_deg`, `settle_time_s`, `settled`.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        table::to_dict(py, &self.columns(py)?)
    }
    /// The columns of `to_dict` as a pandas DataFrame (ImportError without pandas).
    fn to_pandas<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        table::to_pandas(py, "Plan", &self.columns(py)?)
    }
    fn _repr_html_(&self, py: Python<'_>) -> PyResult<String> {
        table::to_html(&self.__repr__(), &self.columns(py)?)
    }
    fn __repr__(&self) -> String {
        let s = self.plan.summary(&self.settings);
        format!(
            "Plan({}, final angle {:.2} deg, worst axis error {:.2} deg, path deviation \
             {:.2} deg, {})",
            steps_and_rows(self.plan.rows.len()),
            s.final_angle_deg,
            s.max_axis_error_deg,
            s.max_path_deviation_deg,
            if s.reached { "reached" } else { "NOT reached" }
        )
    }
}

/// A plan replayed through the dynamics: per step where the ball settled and how far that is
/// from the plan's prediction.
#[pyclass(frozen, module = "spherestep")]
pub struct Simulation {
    pub(crate) rows: Vec<SimRow>,
}

impl Simulation {
    fn columns<'py>(&self, py: Python<'py>) -> PyResult<Columns<'py>> {
        let mut c: Columns<'py> = vec![("step".into(), self.step(py).into_any())];
        push_q(&mut c, "", self.q(py)?.as_any())?;
        c.push(("deviation_deg".into(), self.deviation_deg(py).into_any()));
        c.push(("settled".into(), self.settled(py).into_any()));
        c.push(("settle_time_s".into(), self.settle_time_s(py).into_any()));
        Ok(c)
    }
}

#[pymethods]
impl Simulation {
    /// The plan's step numbers.
    #[getter]
    fn step<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        column(py, self.rows.iter().map(|r| r.step as i64).collect())
    }
    /// Where the ball settled at each step, shape `(rows, 4)`: `[qx, qy, qz, qw]`.
    #[getter]
    fn q<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        q_rows(py, self.rows.iter().map(|r| &r.q))
    }
    /// The angle between where the ball settled and the plan's prediction, degrees.
    #[getter]
    fn deviation_deg<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        column(py, self.rows.iter().map(|r| r.deviation_deg).collect())
    }
    /// Whether the ball settled within t_max at each step.
    #[getter]
    fn settled<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        column(py, self.rows.iter().map(|r| r.settled).collect())
    }
    /// How long each settle took, s.
    #[getter]
    fn settle_time_s<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        column(py, self.rows.iter().map(|r| r.settle_time_s).collect())
    }
    /// The summary (`steps`, `max_deviation_deg`, `final_deviation_deg`, `unsettled_steps`).
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        summary_dict(py, &sim_summary(&self.rows))
    }
    /// The replay as CSV text: what `spherestep simulate --out` writes.
    fn csv(&self) -> PyResult<String> {
        let mut buf = Vec::new();
        write_sim(&self.rows, &mut buf).map_err(lib_err)?;
        Ok(text(buf))
    }
    /// The rows: row 0 the initial commutation state, then one per step.
    fn __len__(&self) -> usize {
        self.rows.len()
    }
    /// The columns as a dict of lists, one per row: `step`, `qx`, `qy`, `qz`, `qw`,
    /// `deviation_deg`, `settled`, `settle_time_s`.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        table::to_dict(py, &self.columns(py)?)
    }
    /// The columns of `to_dict` as a pandas DataFrame (ImportError without pandas).
    fn to_pandas<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        table::to_pandas(py, "Simulation", &self.columns(py)?)
    }
    fn _repr_html_(&self, py: Python<'_>) -> PyResult<String> {
        table::to_html(&self.__repr__(), &self.columns(py)?)
    }
    fn __repr__(&self) -> String {
        let s = sim_summary(&self.rows);
        format!(
            "Simulation({}, max deviation {:.4} deg)",
            steps_and_rows(self.rows.len()),
            s.max_deviation_deg
        )
    }
}

/// A well's torque curve: the torque on one magnet passing one energised coil against the
/// angle between them, and its summary.
#[pyclass(frozen, module = "spherestep")]
pub struct Wells {
    pub(crate) curve: Vec<(f64, f64)>,
    pub(crate) summary: WellSummary,
}

impl Wells {
    fn columns<'py>(&self, py: Python<'py>) -> PyResult<Columns<'py>> {
        Ok(vec![
            ("angle_deg".into(), self.angle_deg(py).into_any()),
            ("torque_nm".into(), self.torque_nm(py).into_any()),
        ])
    }
}

#[pymethods]
impl Wells {
    /// The angles, degrees, from 0 to the cut-off.
    #[getter]
    fn angle_deg<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        column(py, self.curve.iter().map(|c| c.0).collect())
    }
    /// The pull at each angle, N m (positive: towards the coil).
    #[getter]
    fn torque_nm<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        column(py, self.curve.iter().map(|c| c.1).collect())
    }
    /// The summary: peak pull and its angle, cut-off, stiffness, half-peak width.
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        summary_dict(py, &self.summary)
    }
    /// The curve as CSV text in the `table` format (`angle_deg,torque_nm`), what
    /// `spherestep wells --out` writes.
    fn csv(&self) -> PyResult<String> {
        let bytes = csv_bytes(
            "the well curve",
            &["angle_deg", "torque_nm"],
            self.curve
                .iter()
                .map(|(a, g)| vec![a.to_string(), g.to_string()]),
        )
        .map_err(lib_err)?;
        Ok(text(bytes))
    }
    fn __len__(&self) -> usize {
        self.curve.len()
    }
    /// The columns as a dict of lists: `angle_deg`, `torque_nm`.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        table::to_dict(py, &self.columns(py)?)
    }
    /// The columns of `to_dict` as a pandas DataFrame (ImportError without pandas).
    fn to_pandas<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        table::to_pandas(py, "Wells", &self.columns(py)?)
    }
    fn _repr_html_(&self, py: Python<'_>) -> PyResult<String> {
        table::to_html(&self.__repr__(), &self.columns(py)?)
    }
    fn __repr__(&self) -> String {
        format!(
            "Wells({} rows, peak {:.4} N m at {:.2} deg)",
            self.summary.rows, self.summary.peak_torque_nm, self.summary.peak_angle_deg
        )
    }
}

/// A motion played on a plant, open or closed loop: per step what was on, the planned,
/// measured and true orientations, the true cumulative rotation and distance to the goal.
#[pyclass(frozen, module = "spherestep")]
pub struct Run {
    pub(crate) run: LoopRun,
    pub(crate) closed_loop: bool,
    pub(crate) sensor_noise_deg: f64,
    pub(crate) seed: u64,
    pub(crate) planned_steps: usize,
    /// The motor's coils (the width of `active_magnet`).
    pub(crate) coils: usize,
}

impl Run {
    fn columns<'py>(&self, py: Python<'py>) -> PyResult<Columns<'py>> {
        let mut c: Columns<'py> = vec![
            ("step".into(), self.step(py).into_any()),
            ("active".into(), self.active().into_bound_py_any(py)?),
            ("replanned".into(), self.replanned(py).into_any()),
        ];
        push_q(&mut c, "planned_", self.planned_q(py)?.as_any())?;
        push_q(&mut c, "measured_", self.measured_q(py)?.as_any())?;
        push_q(&mut c, "true_", self.true_q(py)?.as_any())?;
        for (name, f) in [
            (
                "cum_angle_deg",
                Run::cum_angle_deg as fn(&Run, Python<'py>) -> _,
            ),
            ("cum_axis_error_deg", Run::cum_axis_error_deg),
            ("error_to_goal_deg", Run::error_to_goal_deg),
        ] {
            c.push((name.into(), f(self, py).into_any()));
        }
        c.push(("settled".into(), self.settled(py).into_any()));
        c.push(("settle_time_s".into(), self.settle_time_s(py).into_any()));
        Ok(c)
    }

    fn numbers<'py>(
        &self,
        py: Python<'py>,
        f: fn(&spherestep::LoopRow) -> f64,
    ) -> Bound<'py, PyArray1<f64>> {
        column(py, self.run.rows.iter().map(f).collect())
    }
}

#[pymethods]
impl Run {
    /// The step numbers (0: the initial commutation state).
    #[getter]
    fn step<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        column(py, self.run.rows.iter().map(|r| r.step as i64).collect())
    }
    /// What was on at each step, as `(coil, magnet)` pairs.
    #[getter]
    fn active(&self) -> Vec<Vec<(usize, usize)>> {
        self.run
            .rows
            .iter()
            .map(|r| pair_tuples(&r.active))
            .collect()
    }
    /// What was on at each step as indices, shape `(rows, coils)` (`int64`): row k, column c
    /// is the magnet coil c pulled at step k, -1 where coil c was off.
    #[getter]
    fn active_magnet<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        magnet_per_coil(py, self.run.rows.iter().map(|r| &r.active[..]), self.coils)
    }
    /// Whether the rest of the motion was replanned after each step's measurement.
    #[getter]
    fn replanned<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        column(py, self.run.rows.iter().map(|r| r.replanned).collect())
    }
    /// Where the plan in force said the ball would be, shape `(rows, 4)`.
    #[getter]
    fn planned_q<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        q_rows(py, self.run.rows.iter().map(|r| &r.planned))
    }
    /// Where the sensor said the ball was, shape `(rows, 4)`.
    #[getter]
    fn measured_q<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        q_rows(py, self.run.rows.iter().map(|r| &r.measured))
    }
    /// Where the ball was, shape `(rows, 4)`.
    #[getter]
    fn true_q<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        q_rows(py, self.run.rows.iter().map(|r| &r.truth))
    }
    /// The true cumulative rotation's angle about the target axis, degrees.
    #[getter]
    fn cum_angle_deg<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.numbers(py, |r| r.cum_angle_deg)
    }
    /// The true cumulative rotation's axis error, degrees.
    #[getter]
    fn cum_axis_error_deg<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.numbers(py, |r| r.cum_axis_error_deg)
    }
    /// The true orientation's angle from the goal, degrees.
    #[getter]
    fn error_to_goal_deg<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.numbers(py, |r| r.error_to_goal_deg)
    }
    /// Whether each step settled within t_max on the plant.
    #[getter]
    fn settled<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        column(py, self.run.rows.iter().map(|r| r.settled).collect())
    }
    /// Each step's settle time on the plant, s.
    #[getter]
    fn settle_time_s<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.numbers(py, |r| r.settle_time_s)
    }
    /// The summary, with the keys of `spherestep run --json`.
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let s = RunSummary::new(
            self.closed_loop,
            self.sensor_noise_deg,
            self.seed,
            self.planned_steps,
            self.run.summary.clone(),
        );
        summary_dict(py, &s)
    }
    /// The run as CSV text: what `spherestep run --out` writes.
    fn csv(&self) -> PyResult<String> {
        let mut buf = Vec::new();
        write_loop(&self.run.rows, &mut buf).map_err(lib_err)?;
        Ok(text(buf))
    }
    /// The rows: row 0 the initial commutation state, then one per step played.
    fn __len__(&self) -> usize {
        self.run.rows.len()
    }
    /// The columns as a dict of lists, one per row: `step`, `active`, `replanned`,
    /// `planned_qx` .. `planned_qw`, `measured_qx` .. `measured_qw`, `true_qx` .. `true_qw`,
    /// `cum_angle_deg`, `cum_axis_error_deg`, `error_to_goal_deg`, `settled`, `settle_time_s`.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        table::to_dict(py, &self.columns(py)?)
    }
    /// The columns of `to_dict` as a pandas DataFrame (ImportError without pandas).
    fn to_pandas<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        table::to_pandas(py, "Run", &self.columns(py)?)
    }
    fn _repr_html_(&self, py: Python<'_>) -> PyResult<String> {
        table::to_html(&self.__repr__(), &self.columns(py)?)
    }
    fn __repr__(&self) -> String {
        let s = &self.run.summary;
        format!(
            "Run({} loop, {}, {} replans, {:.2} deg from the goal, {})",
            if self.closed_loop { "closed" } else { "open" },
            steps_and_rows(self.run.rows.len()),
            s.replans,
            s.final_error_deg,
            if s.reached { "reached" } else { "NOT reached" }
        )
    }
}
