//! `spherestep fit`: a scenario's wells fitted to what the bench measures, a torque curve
//! (`--torque`) and/or a closed-loop replay's log of measured steps (`--log`, the last
//! `--holdout` steps predicted and not fitted), or a physical scenario's `core_gain` and `gap_m`
//! fitted to the curve (`--as`), reported with each parameter's standard error and the
//! residuals, and written as a scenario every command loads (`--out`).

use crate::commands::args::check_out;
use crate::error::{Error, Result};
use crate::io::fitfiles::{fitted_toml, Fitted};
pub use crate::io::fitting::{fit, FitAs, FitInputs, FitReport};
use crate::io::output::write_atomic;
use crate::io::scenario::Scenario;
use crate::planning::fit::{describe, FitError, StepFit};
use crate::planning::fit_parts::PartsFit;
use crate::text::printable;
use std::io::Write;
use std::path::Path;

/// The report in words, one line each (what `fit` prints, and the fitted file's comment).
pub fn report_lines(sc: &Scenario, inputs: &FitInputs, r: &FitReport) -> Vec<String> {
    let mut lines = Vec::new();
    if let (Some(p), Some(parts)) = (inputs.torque, &r.parts) {
        lines.extend(parts_lines(sc, p, parts));
    }
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

/// The lines of a physical scenario's fit.
fn parts_lines(sc: &Scenario, torque: &Path, f: &PartsFit) -> Vec<String> {
    let value = |k: usize, digits: usize| {
        let e = &f.estimates[k];
        match e.std_error {
            Some(se) => format!("{} = {:.*} +- {:.*}", e.key, digits, e.value, digits, se),
            None => format!("{} = {:.*}", e.key, digits, e.value),
        }
    };
    let mut lines = vec![
        format!(
            "{}: torque curve {}, {} points, fitted as its physical parts (core_gain and gap_m; \
             the magnet, the winding and the current kept)",
            printable(&sc.name),
            torque.display(),
            f.points
        ),
        format!(
            "  rms residual {:.6} N m ({:.6} with the scenario's core_gain {} and gap_m {} m)",
            f.rms_nm, f.start_rms_nm, f.start.core_gain, f.start.gap_m
        ),
        format!("  {}, {}", value(0, 4), value(1, 7)),
    ];
    if let Some(w) = f.core_gain_wanted {
        lines.push(format!(
            "  the curve asks for core_gain {w:.4}, below 1 (an air coil, the least the format \
             allows): held at 1, gap_m fitted alone; the coil pulls less than its winding does \
             (check the current, the turns, the magnet)"
        ));
    }
    lines.push(format!(
        "  fitted: peak pull {:.4} N m at {:.2} deg, reaching {:.2} deg",
        f.peak_nm, f.peak_deg, f.reach_deg
    ));
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
        let fitted = match (&report.parts, &report.wells) {
            (Some(p), _) => Fitted::Parts(p.fitted),
            (None, Some(w)) => Fitted::Wells(*w, report.interaction),
            (None, None) => return Err(FitError::Unfit("nothing fitted".into()).into()),
        };
        let text = fitted_toml(sc, &fitted, path, &header)?;
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
