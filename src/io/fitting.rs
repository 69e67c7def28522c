//! A scenario fitted to what the bench measures, from its files: a torque curve (`--torque`)
//! and/or a closed-loop replay's log (`--log`), as gaussian or cosine wells or, for a physical
//! scenario (`shape = "dipole"`), as its parts' `core_gain` and `gap_m`. What `spherestep fit`
//! and the Python `spherestep.fit` share; the printing and the fitted file are the command's.
//! An error of the fit names the file it came from.

use crate::error::{Error, Result};
use crate::io::fitfiles::{read_bench, read_steps};
use crate::io::scenario::Scenario;
use crate::physics::torque::{Interaction, WellShape};
use crate::planning::fit::{
    fit_curve, fit_shape, fit_steps, CurveFit, FitError, FitShape, StepFit, WellFit,
};
use crate::planning::fit_parts::{fit_parts, PartsFit, PartsModel};
use serde::Serialize;
use std::path::Path;

/// What the curve is fitted as (`fit --as`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FitAs {
    /// Gaussian and cosine wells, the better chosen (the default but for a physical scenario).
    Wells,
    /// Gaussian wells.
    Gaussian,
    /// Cosine wells.
    Cosine,
    /// A physical scenario's `core_gain` and `gap_m` (its default).
    Physical,
}

impl FitAs {
    /// The names `--as` takes.
    pub const NAMES: [&'static str; 4] = ["wells", "gaussian", "cosine", "physical"];

    /// The choice of this name (`None`: no such choice).
    pub fn parse(name: &str) -> Option<FitAs> {
        match name {
            "wells" => Some(FitAs::Wells),
            "gaussian" => Some(FitAs::Gaussian),
            "cosine" => Some(FitAs::Cosine),
            "physical" => Some(FitAs::Physical),
            _ => None,
        }
    }
}

/// What `fit` is given.
#[derive(Debug, Clone, Copy, Default)]
pub struct FitInputs<'a> {
    /// A bench's torque curve (`angle_deg,torque_nm`).
    pub torque: Option<&'a Path>,
    /// A closed-loop replay's log (`replay --sensor --log`).
    pub log: Option<&'a Path>,
    /// The last steps of the log kept out of the fit and predicted.
    pub holdout: usize,
    /// Where the fitted scenario goes (the command writes it).
    pub out: Option<&'a Path>,
    /// What the curve is fitted as (`None`: physical for a physical scenario, else wells).
    pub fit_as: Option<FitAs>,
}

/// What `fit` found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FitReport {
    /// What the curve was fitted as.
    pub fitted_as: FitAs,
    /// The curve's fits as wells, the least residual first (the first chosen).
    pub curve: Vec<CurveFit>,
    /// The physical parts' fit (`fitted_as` physical).
    pub parts: Option<PartsFit>,
    /// The steps' fit.
    pub steps: Option<StepFit>,
    /// The wells written: the steps' fit, else the curve's (`None`: the parts are written).
    pub wells: Option<WellFit>,
    /// The interaction written (the scenario's: a curve or a log does not tell it).
    pub interaction: Interaction,
    /// The measured steps the log held.
    pub logged_steps: usize,
}

/// A fit's error, named by the file whose data it fitted.
fn in_file(path: &Path) -> impl Fn(FitError) -> Error + '_ {
    move |e| Error::Parse {
        file: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// What the curve is fitted as: `asked`, else physical for a physical scenario and wells for
/// any other; physical only for a physical scenario, and from a torque curve alone.
fn fit_as(sc: &Scenario, inputs: &FitInputs) -> Result<FitAs> {
    let dipole = matches!(sc.torques.well.shape(), WellShape::Dipole(_));
    let chosen = inputs.fit_as.unwrap_or(if dipole {
        FitAs::Physical
    } else {
        FitAs::Wells
    });
    let arg = |expected: &str| Error::Arg {
        arg: "--as".into(),
        expected: expected.into(),
    };
    if chosen == FitAs::Physical {
        if !dipole {
            return Err(arg(
                "physical only for a physical scenario (magnets.shape = \"dipole\"): wells, \
                 gaussian or cosine for this one",
            ));
        }
        if inputs.log.is_some() || inputs.torque.is_none() {
            return Err(arg(
                "physical (the default for a physical scenario) with a torque curve alone \
                 (--torque), which fits core_gain and gap_m: a replay log (--log) fits wells, \
                 so give --as wells, gaussian or cosine with it",
            ));
        }
    }
    Ok(chosen)
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
    let fitted_as = fit_as(sc, inputs)?;
    let mut report = FitReport {
        fitted_as,
        curve: Vec::new(),
        parts: None,
        steps: None,
        wells: None,
        interaction: sc.torques.interaction,
        logged_steps: 0,
    };
    if let (FitAs::Physical, Some(p)) = (fitted_as, inputs.torque) {
        let model = PartsModel::of(&sc.torques.well).map_err(in_file(&sc.path))?;
        report.parts = Some(fit_parts(&model, &read_bench(p)?).map_err(in_file(p))?);
        return Ok(report);
    }
    if let Some(p) = inputs.torque {
        let pts = read_bench(p)?;
        report.curve = match fitted_as {
            FitAs::Gaussian => vec![fit_shape(FitShape::Gaussian, &pts).map_err(in_file(p))?],
            FitAs::Cosine => vec![fit_shape(FitShape::Cosine, &pts).map_err(in_file(p))?],
            _ => fit_curve(&pts).map_err(in_file(p))?,
        };
    }
    let start = match report.curve.first() {
        Some(c) => c.wells,
        None => WellFit::of(&sc.torques.well).ok_or_else(|| {
            FitError::Unfit(
                "the scenario's wells are measured or physical (shape \"table\" or \"dipole\"): \
                 fit a bench curve too (--torque), whose gaussian or cosine fit the log then refines"
                    .into(),
            )
        })?,
    };
    report.wells = Some(start);
    if let Some(p) = inputs.log {
        let measured = read_steps(p, sc.torques.stator.len())?;
        let fitted =
            fit_steps(&sc.motor(), &start, &measured, inputs.holdout).map_err(in_file(p))?;
        report.wells = Some(fitted.wells);
        report.steps = Some(fitted);
        report.logged_steps = measured.len();
    }
    Ok(report)
}
