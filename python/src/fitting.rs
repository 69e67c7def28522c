//! `spherestep.fit`: a scenario fitted to what the bench measures (a torque curve and/or a
//! closed-loop replay's log), the library's own fit (`spherestep fit`, without its printing):
//! the fitted parameters and their standard errors as dicts, with the whole report.

use crate::convert::{shown, summary_dict};
use crate::motor::Scenario;
use crate::{arg_err, lib_err};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use spherestep::io::fitting::{fit as fit_files, FitAs, FitInputs, FitReport};
use spherestep::planning::fit::Estimate;
use std::path::PathBuf;
use std::sync::Arc;

/// The estimates a report's parameters are: a physical fit's, else the curve's chosen fit's
/// with the log's fit (if any) replacing the ones it fits.
fn estimates(r: &FitReport) -> Vec<Estimate> {
    if let Some(p) = &r.parts {
        return p.estimates.clone();
    }
    let mut list: Vec<Estimate> = r
        .curve
        .first()
        .map(|c| c.estimates.clone())
        .unwrap_or_default();
    for e in r.steps.iter().flat_map(|s| &s.estimates) {
        match list.iter_mut().find(|x| x.key == e.key) {
            Some(x) => *x = e.clone(),
            None => list.push(e.clone()),
        }
    }
    list
}

/// A scenario given as a `Scenario` or a path to its file.
fn scenario(obj: &Bound<'_, PyAny>) -> PyResult<Arc<spherestep::Scenario>> {
    if let Ok(s) = obj.cast::<Scenario>() {
        return Ok(s.get().sc.clone());
    }
    let path: PathBuf = obj.extract().map_err(|_| {
        arg_err(
            "scenario",
            format!(
                "a Scenario or the path of a scenario file, got {}",
                shown(obj)
            ),
        )
    })?;
    Ok(Arc::new(
        spherestep::Scenario::load(&path).map_err(lib_err)?,
    ))
}

/// Fits `scenario` (a `Scenario` or a scenario file's path) to a bench's torque curve `torque`
/// (a CSV of `angle_deg,torque_nm`) and/or a closed-loop replay's log `log` (`replay --sensor
/// --log`; its last `holdout` steps predicted, not fitted), as `spherestep fit` does: a
/// physical scenario (`shape = "dipole"`) fits its `core_gain` and `gap_m` (`fit_as =
/// "physical"`, its default), any other its wells (`"wells"`: gaussian and cosine, the better
/// chosen; or `"gaussian"`, `"cosine"`). Returns a dict: `fitted_as`, `parameters` (each
/// fitted key of `[magnets]` and its value), `std_errors` (the same keys; None where the data
/// do not determine it), `rms_nm` (the curve's RMS residual, N m; None without a curve) and
/// `report` (the whole report, the keys of `spherestep fit --json`). A file that cannot be
/// read or fitted raises `spherestep.Error` naming it.
#[pyfunction]
#[pyo3(signature = (scenario, torque = None, log = None, *, holdout = 0, fit_as = None))]
pub fn fit<'py>(
    py: Python<'py>,
    scenario: &Bound<'py, PyAny>,
    torque: Option<PathBuf>,
    log: Option<PathBuf>,
    holdout: usize,
    fit_as: Option<&str>,
) -> PyResult<Bound<'py, PyDict>> {
    let sc = self::scenario(scenario)?;
    let fit_as = match fit_as {
        None => None,
        Some(name) => Some(FitAs::parse(name).ok_or_else(|| {
            arg_err(
                "fit_as",
                format!("one of {}, got '{name}'", FitAs::NAMES.join(", ")),
            )
        })?),
    };
    let inputs = FitInputs {
        torque: torque.as_deref(),
        log: log.as_deref(),
        holdout,
        out: None,
        fit_as,
    };
    let report = py.detach(|| fit_files(&sc, &inputs)).map_err(|e| {
        // the command line's flags are the keyword arguments here
        let text = e
            .to_string()
            .replace("argument --torque/--log", "argument torque/log")
            .replace("argument --as", "argument fit_as");
        crate::Error::new_err(text)
    })?;
    let (values, errors) = (PyDict::new(py), PyDict::new(py));
    for e in estimates(&report) {
        values.set_item(e.key, e.value)?;
        errors.set_item(e.key, e.std_error)?;
    }
    let rms = match (&report.parts, report.curve.first()) {
        (Some(p), _) => Some(p.rms_nm),
        (None, Some(c)) => Some(c.rms_nm),
        _ => None,
    };
    let out = PyDict::new(py);
    out.set_item("fitted_as", summary_dict(py, &report.fitted_as)?)?;
    out.set_item("parameters", values)?;
    out.set_item("std_errors", errors)?;
    out.set_item("rms_nm", rms)?;
    out.set_item("report", summary_dict(py, &report)?)?;
    Ok(out)
}
