//! `spherestep fit`: a scenario's wells fitted to what the bench measures, a torque curve
//! (`--torque`) and/or a closed-loop replay's log of measured steps (`--log`, the last
//! `--holdout` steps predicted and not fitted), reported with each parameter's standard error
//! and the residuals, and written as a scenario every command loads (`--out`).

use crate::commands::args::check_out;
use crate::error::{Error, Result};
use crate::io::fitfiles::{fitted_toml, read_bench, read_steps};
use crate::io::output::write_atomic;
use crate::io::scenario::Scenario;
use crate::physics::torque::Interaction;
use crate::planning::fit::{describe, fit_curve, fit_steps, CurveFit, FitError, StepFit, WellFit};
use crate::text::printable;
use serde::Serialize;
use std::io::Write;
use std::path::Path;

/// What `fit` is given.
#[derive(Debug, Clone, Copy)]
pub struct FitInputs<'a> {
    /// A bench's torque curve (`angle_deg,torque_nm`).
    pub torque: Option<&'a Path>,
    /// A closed-loop replay's log (`replay --sensor --log`).
    pub log: Option<&'a Path>,
    /// The last steps of the log kept out of the fit and predicted.
    pub holdout: usize,
    /// Where the fitted scenario goes.
    pub out: Option<&'a Path>,
}

/// What `fit` found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FitReport {
    /// The curve's fits, the least residual first (the first chosen).
    pub curve: Vec<CurveFit>,
    /// The steps' fit.
    pub steps: Option<StepFit>,
    /// The wells written: the steps' fit, else the curve's.
    pub wells: WellFit,
    /// The interaction written (the scenario's: a curve or a log does not tell it).
    pub interaction: Interaction,
    /// The measured steps the log held.
    pub logged_steps: usize,
}

/// The fits of `inputs` on `sc`'s motor.
pub fn fit(sc: &Scenario, inputs: &FitInputs) -> Result<FitReport> {
    if inputs.torque.is_none() && inputs.log.is_none() {
        return Err(Error::Arg {
            arg: "--torque/--log".into(),
            expected: "a bench's torque curve (--torque FILE), a replay log (--log FILE), or both"
                .into(),
        });
    }
    let curve = match inputs.torque {
        Some(p) => fit_curve(&read_bench(p)?)?,
        None => Vec::new(),
    };
    let start = match curve.first() {
        Some(c) => c.wells,
        None => WellFit::of(&sc.torques.well).ok_or_else(|| {
            FitError::Unfit(
                "the scenario's wells are measured or physical (shape \"table\" or \"dipole\"): \
                 fit a bench curve too (--torque), whose gaussian or cosine fit the log then refines"
                    .into(),
            )
        })?,
    };
    let motor = sc.motor();
    let (steps, logged) = match inputs.log {
        Some(p) => {
            let measured = read_steps(p, sc.torques.stator.len())?;
            let fitted = fit_steps(&motor, &start, &measured, inputs.holdout)?;
            (Some(fitted), measured.len())
        }
        None => (None, 0),
    };
    Ok(FitReport {
        wells: steps.as_ref().map_or(start, |s| s.wells),
        curve,
        steps,
        interaction: sc.torques.interaction,
        logged_steps: logged,
    })
}

/// The report in words, one line each (what `fit` prints, and the fitted file's comment).
pub fn report_lines(sc: &Scenario, inputs: &FitInputs, r: &FitReport) -> Vec<String> {
    let mut lines = Vec::new();
    if let (Some(p), Some(first)) = (inputs.torque, r.curve.first()) {
        lines.push(format!(
            "{}: torque curve {}, {} points",
            printable(&sc.name),
            p.display(),
            first.points
        ));
        for c in &r.curve {
            let params: Vec<String> = c.estimates.iter().map(|e| e.text()).collect();
            lines.push(format!(
                "  {:<8} rms residual {:.6} N m; {}",
                c.wells.shape.name(),
                c.rms_nm,
                params.join(", ")
            ));
        }
        lines.push(format!("  chosen: {}", describe(&first.wells)));
    }
    if let (Some(p), Some(s)) = (inputs.log, &r.steps) {
        lines.extend(step_lines(p, r, s));
    }
    lines
}

/// The lines of the steps' fit.
fn step_lines(log: &Path, r: &FitReport, s: &StepFit) -> Vec<String> {
    let rms = |e: &[f64]| (e.iter().map(|v| v * v).sum::<f64>() / e.len().max(1) as f64).sqrt();
    let worst = |e: &[f64]| e.iter().copied().fold(0.0, f64::max);
    let params: Vec<String> = s.estimates.iter().map(|e| e.text()).collect();
    let mut lines = vec![
        format!(
            "measured steps {}: {} steps, {} fitted, {} held out; the strength is kept (it moves \
             no equilibrium)",
            log.display(),
            r.logged_steps,
            s.fitted_steps,
            s.holdout_after_deg.len()
        ),
        format!("  {}", params.join(", ")),
        format!(
            "  fitted steps: rms error {:.3} deg with the starting wells, {:.3} deg fitted",
            s.rms_before_deg, s.rms_after_deg
        ),
    ];
    if !s.holdout_after_deg.is_empty() {
        lines.push(format!(
            "  held-out steps: rms error {:.3} deg (worst {:.3}) with the starting wells, {:.3} \
             deg (worst {:.3}) fitted",
            rms(&s.holdout_before_deg),
            worst(&s.holdout_before_deg),
            rms(&s.holdout_after_deg),
            worst(&s.holdout_after_deg)
        ));
    }
    lines.push(format!("  fitted: {}", describe(&s.wells)));
    lines
}

/// `spherestep fit`: fits, prints the report (text, or JSON) to `out` and writes the fitted
/// scenario to `inputs.out` (atomically; it must not replace an input).
pub fn fit_command(
    sc: &Scenario,
    inputs: &FitInputs,
    json: bool,
    out: &mut dyn Write,
) -> Result<FitReport> {
    if let Some(path) = inputs.out {
        let mut read: Vec<&Path> = sc.files.iter().map(|p| p.as_path()).collect();
        read.extend(inputs.torque.iter().chain(inputs.log.iter()));
        check_out(path, &read)?;
    }
    let report = fit(sc, inputs)?;
    let lines = report_lines(sc, inputs, &report);
    if let Some(path) = inputs.out {
        let header: String = lines.iter().map(|l| format!("# {l}\n")).collect();
        let text = fitted_toml(sc, &report.wells, report.interaction, path, &header)?;
        write_atomic(path, text.as_bytes())?;
    }
    let w = |e| Error::io("<stdout>", e);
    if json {
        let text = serde_json::to_string(&report).map_err(|e| Error::json("the fit", e))?;
        writeln!(out, "{text}").map_err(w)?;
    } else {
        for l in &lines {
            writeln!(out, "{l}").map_err(w)?;
        }
        if let Some(p) = inputs.out {
            writeln!(out, "wrote {}", p.display()).map_err(w)?;
        }
    }
    Ok(report)
}
