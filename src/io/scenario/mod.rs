//! Scenario files (TOML): which motor (rotor and stator packings, magnet wells), which body and
//! damping, how to settle. Unknown keys are rejected; every value is checked, and an error names
//! the file, the field and what was expected. Every section has defaults (the prototype).
//!
//! Reading is in two parts: `raw` (the file as written, serde structs) and `checked` (the
//! checks that make a [`Scenario`] of it); this file holds the checked types.

mod changes;
mod checked;
mod design;
mod parts;
mod raw;

pub use changes::{ChangeNames, PlanChanges, PlanInput, RowsFrom};
use checked::Checker;
use raw::*;

use crate::error::{Error, Result};
use crate::model::geometry::{Orientation, Pair, Radians, UnitVec};
use crate::model::packing::Packing;
use crate::model::random::SplitMix;
use crate::physics::dynamics::{Body, SettleParams};
use crate::physics::torque::MagnetTorques;
use crate::planning::commutation::{Motor, PairsPerStep, StepModel};
use crate::planning::planner::{PlanSettings, Scheme};
use crate::text::{printable, shown};
use nalgebra::Vector3;
use std::path::{Path, PathBuf};

/// Defaults of the `[magnets]` section (docs/scenario-format.md; scenarios/prototype.toml says
/// where each comes from): `strength_j`, a well's strength k (joules).
pub const DEFAULT_STRENGTH_J: f64 = 0.25;
/// `magnets.width_deg`: the sigma of a gaussian well (degrees).
pub const DEFAULT_WIDTH_DEG: f64 = 10.0;
/// `magnets.max_attraction_deg`: no pull beyond this angle between coil and magnet (degrees).
pub const DEFAULT_MAX_ATTRACTION_DEG: f64 = 30.0;
/// The radius of the magnets' centres (m) of shape = "dipole" when not given: the prototype's
/// 12 inch ball.
pub const DEFAULT_BALL_RADIUS_M: f64 = 0.1524;
/// Two magnets (or two coils) closer than this (chord of the unit sphere, about 6e-5 degrees)
/// are the same place: refused.
pub const COINCIDENT_TOL: f64 = 1e-6;
/// Defaults of the `[body]` section: `inertia_kg_m2`, the ball's moment of inertia (kg m^2).
pub const DEFAULT_INERTIA_KG_M2: f64 = 0.023;
/// `body.damping_nms`: the viscous damping c (N m s).
pub const DEFAULT_DAMPING_NMS: f64 = 1.0;

/// The `[report]` section: what the pictures compare against.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReportSettings {
    /// A reference axis error (e.g. the paper's bound), drawn as a line, degrees.
    pub reference_deg: Option<f64>,
    /// The reference line's label (`None`: "paper: <reference_deg> deg").
    pub reference_label: Option<String>,
}

/// A sweep: many planning cases from one scenario (axes x angles x schemes x models, or random
/// motions x schemes x models).
#[derive(Debug, Clone, PartialEq)]
pub struct Sweep {
    /// The axes of rotation (world frame).
    pub axes: Vec<UnitVec>,
    /// The target angles (radians), each in (0, 180] degrees.
    pub angles: Vec<Radians>,
    /// The planners each case is planned with.
    pub schemes: Vec<Scheme>,
    /// (model, pairs per step)
    pub models: Vec<(StepModel, PairsPerStep)>,
    /// Also write each case's plan CSV.
    pub keep_plans: bool,
    /// Random motions (`motions = N`): each case its own start, axis and angle, in place of
    /// the product of `axes` and `angles` (which then hold each motion's axis and angle).
    pub motions: Vec<Motion>,
}

/// One motion of a random-motion sweep: from `start`, `angle` about `axis`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    /// The ball's orientation at the start (body to world).
    pub start: Orientation,
    /// The axis of rotation (world frame).
    pub axis: UnitVec,
    /// The angle to turn about `axis` (radians).
    pub angle: Radians,
}

/// `count` random motions from `seed`: each a start uniform over the rotations, an axis
/// uniform over the sphere and an angle uniform in `[min, max]`, drawn in that order from one
/// [`SplitMix`] (the same motions on every machine).
pub fn random_motions(count: usize, seed: u64, min: Radians, max: Radians) -> Vec<Motion> {
    let mut r = SplitMix::new(seed);
    (0..count)
        .map(|_| {
            let start = r.orientation();
            let axis = r.direction();
            let angle = Radians(min.0 + (max.0 - min.0) * r.uniform());
            Motion { start, axis, angle }
        })
        .collect()
}

/// `count` axes spread evenly over the whole sphere (a Fibonacci lattice), deterministic.
pub fn sphere_axes(count: usize) -> Vec<UnitVec> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..count)
        .map(|k| {
            let z = 1.0 - (2.0 * k as f64 + 1.0) / count as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * k as f64;
            UnitVec::new_normalize(Vector3::new(r * phi.cos(), r * phi.sin(), z))
        })
        .collect()
}

/// A checked scenario: the motor, the body and the settle settings.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// The file it came from (`<built-in>` for the prototype).
    pub path: PathBuf,
    /// The files it was read from: `path` (when loaded from it) and the files it names
    /// (point files, a torque table), as they were opened; what an output must not replace.
    pub files: Vec<PathBuf>,
    /// The scenario's name.
    pub name: String,
    /// What the scenario is for, as its file says.
    pub description: String,
    /// Where the rotor's magnets are (body frame).
    pub rotor: Packing,
    /// Where the stator's coils are (world frame).
    pub stator: Packing,
    /// The torque model built from the packings and the well.
    pub torques: MagnetTorques,
    /// The rotor's inertia and damping.
    pub body: Body,
    /// The settle's tolerances, time limit and integrator.
    pub settle: SettleParams,
    /// Planning settings of the `[plan]` section (command-line options override them).
    pub plan: PlanSettings,
    /// The `[sweep]` section, if any: many cases instead of one plan.
    pub sweep: Option<Sweep>,
    /// The `[report]` section (reference lines of the pictures).
    pub report: ReportSettings,
    /// Relay board (or boards), coil map and replay limits (`[relay]`, see `crate::relay::config`).
    pub relay: crate::relay::RelaySettings,
    /// The orientation sensor's mounting (`[sensor]`, see `crate::io::sensor_section`).
    pub sensor: crate::io::sensor_section::SensorSettings,
    /// The `[design]` section, if any: what `spherestep design` may change and how it searches.
    pub design: Option<crate::planning::design::DesignSpec>,
}

impl Scenario {
    /// The built-in prototype with every default.
    pub fn prototype() -> Scenario {
        Scenario::from_toml("", Path::new("<built-in prototype>"))
            .expect("the defaults form a valid scenario")
    }

    /// The motor of the scenario that commutation, planning and simulation need: its own copy
    /// of the torques, body and settle parameters, independent of the scenario afterwards.
    pub fn motor(&self) -> Motor {
        Motor {
            torques: self.torques.clone(),
            body: self.body,
            settle: self.settle,
            cancel: crate::planning::cancel::Cancel::never(),
        }
    }

    /// Reads and checks a scenario file.
    ///
    /// # Errors
    ///
    /// [`crate::Error::Io`] when a file cannot be read, [`crate::Error::Parse`] for text that
    /// is not a scenario, [`crate::Error::Field`] for a value not allowed.
    ///
    /// # Examples
    ///
    /// ```
    /// use spherestep::Scenario;
    /// use std::path::Path;
    ///
    /// let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/prototype.toml");
    /// let sc = Scenario::load(&path).unwrap();
    /// assert_eq!(sc.path, path);
    /// assert!(sc.motor().plan(&sc.plan).rows.len() > 1);
    /// ```
    pub fn load(path: &Path) -> Result<Scenario> {
        let text = crate::io::input::text(path)?;
        let mut sc = Scenario::from_toml(&text, path)?;
        sc.files.insert(0, path.to_path_buf());
        Ok(sc)
    }

    /// Parses and checks scenario text; `path` names the file in errors and anchors relative
    /// paths (tables, point files).
    pub fn from_toml(text: &str, path: &Path) -> Result<Scenario> {
        let raw: RawScenario = toml::from_str(text).map_err(|e| Error::Parse {
            file: path.to_path_buf(),
            message: e.to_string().trim_end().to_string(),
        })?;
        Scenario::from_raw(raw, path)
    }

    fn from_raw(raw: RawScenario, path: &Path) -> Result<Scenario> {
        let ck = Checker {
            file: path,
            read: Default::default(),
        };
        let rotor = ck.packing(raw.rotor.unwrap_or_default(), "rotor")?;
        let stator = ck.packing(raw.stator.unwrap_or_default(), "stator")?;
        let well_and_interaction = ck.magnets(raw.magnets.unwrap_or_default())?;
        let body = ck.body(raw.body.unwrap_or_default())?;
        let settle = ck.settle(raw.settle.unwrap_or_default())?;
        let torques = MagnetTorques {
            rotor: rotor.points.iter().map(|p| p.into_inner()).collect(),
            stator: stator.points.iter().map(|p| p.into_inner()).collect(),
            well: well_and_interaction.0,
            interaction: well_and_interaction.1,
        };
        ck.well_scale(&torques.well, &settle)?;
        // The relay section first: its limits (coils on at once, one coil's on-time with the
        // replay's dwells) are the planner's, so that replay accepts what is planned.
        let relay = crate::relay::RelaySettings::from_config(
            raw.relay.unwrap_or_default(),
            path,
            "relay.",
        )?;
        let plan = ck.plan(raw.plan.unwrap_or_default(), &torques, &relay)?;
        let sweep = match raw.sweep {
            None => None,
            Some(sw) => Some(ck.sweep(sw, &plan)?),
        };
        let report = match raw.report {
            None => ReportSettings::default(),
            Some(r) => ReportSettings {
                reference_deg: match r.reference_deg {
                    Some(v) if !(v.is_finite() && v >= 0.0) => {
                        return Err(ck.err(
                            "report.reference_deg",
                            format!("a finite angle >= 0 degrees, got {}", shown(v)),
                        ))
                    }
                    v => v,
                },
                reference_label: r.reference_label,
            },
        };
        let design = match raw.design {
            None => None,
            Some(d) => Some(ck.design(d, &stator, &rotor)?),
        };
        let name = raw.name.unwrap_or_else(|| {
            path.file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "scenario".into())
        });
        Ok(Scenario {
            path: path.to_path_buf(),
            files: ck.read.into_inner(),
            name,
            description: raw.description.unwrap_or_default(),
            rotor,
            stator,
            torques,
            body,
            settle,
            plan,
            sweep,
            report,
            relay,
            sensor: crate::io::sensor_section::check(raw.sensor, path)?,
            design,
        })
    }

    /// Checks an active set against this motor: indices in range, no coil used twice.
    pub fn check_active(&self, active: &[Pair], arg: &str) -> Result<()> {
        if active.is_empty() {
            return Err(Error::Arg {
                arg: arg.into(),
                expected: "at least one coil:magnet pair".into(),
            });
        }
        for (k, p) in active.iter().enumerate() {
            if p.coil.0 >= self.stator.len() {
                return Err(Error::Arg {
                    arg: arg.into(),
                    expected: format!(
                        "coil index below {} (the stator's coil count), got {} in pair {p}",
                        self.stator.len(),
                        p.coil
                    ),
                });
            }
            if p.magnet.0 >= self.rotor.len() {
                return Err(Error::Arg {
                    arg: arg.into(),
                    expected: format!(
                        "magnet index below {} (the rotor's magnet count), got {} in pair {p}",
                        self.rotor.len(),
                        p.magnet
                    ),
                });
            }
            if active[..k].iter().any(|o| o.coil == p.coil) {
                return Err(Error::Arg {
                    arg: arg.into(),
                    expected: format!("each coil at most once, got coil {} twice", p.coil),
                });
            }
        }
        Ok(())
    }
}

impl Scenario {
    /// Checks that `plant` has this scenario's packings, so that a plan made here can be
    /// replayed in the plant's physics: as many magnets and coils, each at the same place
    /// (within [`COINCIDENT_TOL`]). The error names both scenarios, the counts and the first
    /// magnet or coil that differs.
    pub fn check_same_packings(&self, plant: &Scenario, arg: &str) -> Result<()> {
        let counts = |sc: &Scenario| {
            format!(
                "{} ({}): {} magnets, {} coils",
                printable(&sc.name),
                sc.path.display(),
                sc.rotor.len(),
                sc.stator.len()
            )
        };
        let moved = |what: &str, a: &Packing, b: &Packing| {
            a.points
                .iter()
                .zip(&b.points)
                .position(|(p, q)| (p.into_inner() - q.into_inner()).norm() > COINCIDENT_TOL)
                .map(|k| {
                    let d = crate::model::geometry::angular_distance(&a.points[k], &b.points[k]);
                    format!("{what} {k} {:.4} deg from the plan's", d.0.to_degrees())
                })
        };
        let differs = if self.rotor.len() != plant.rotor.len() {
            Some("other magnet count".to_string())
        } else if self.stator.len() != plant.stator.len() {
            Some("other coil count".to_string())
        } else {
            moved("magnet", &self.rotor, &plant.rotor)
                .or_else(|| moved("coil", &self.stator, &plant.stator))
        };
        match differs {
            None => Ok(()),
            Some(d) => Err(Error::Arg {
                arg: arg.into(),
                expected: format!(
                    "a plant with the plan's packings ({}), got {}: {d}",
                    counts(self),
                    counts(plant)
                ),
            }),
        }
    }
}

/// Checks a step model's pairs per step: the pivot model takes exactly 2, the dynamic 2 to 8;
/// the coil-set model 2 to 8 coils on after each step.
pub fn check_pairs_per_step(
    model: StepModel,
    pairs: PairsPerStep,
) -> std::result::Result<(), String> {
    let limit = PairsPerStep::LIMIT;
    match model {
        StepModel::Pivot if pairs == PairsPerStep::exactly(2) => Ok(()),
        StepModel::Pivot => Err(format!("2 pairs per step for the pivot model, got {pairs}")),
        StepModel::Dynamic if pairs.min >= 2 && pairs.min <= pairs.max && pairs.max <= limit => {
            Ok(())
        }
        StepModel::Dynamic => Err(format!(
            "2 to {limit} pairs per step for the dynamic model, got {pairs}"
        )),
        StepModel::Coils if pairs.min >= 2 && pairs.min <= pairs.max && pairs.max <= limit => {
            Ok(())
        }
        StepModel::Coils => Err(format!(
            "2 to {limit} coils on after each step for the coil-set model, got {pairs}"
        )),
    }
}

/// Checks pairs (or coils) per step against the supply: a step's set is on after it, so a step
/// of more than `max_coils_on` pairs can never be switched (the search would find no step
/// and blame its budget).
pub fn check_supply(pairs: PairsPerStep, max_coils_on: usize) -> std::result::Result<(), String> {
    if pairs.min <= max_coils_on {
        return Ok(());
    }
    Err(format!(
        "pairs per step the supply can switch: {pairs} pairs (coils) on after a step need at \
         least {} coils on at once, and plan.max_coils_on is {max_coils_on} (a step's new \
         coils go on before the held ones go off)",
        pairs.min
    ))
}

/// Parses pairs per step written `K` (exactly K) or `2-K` (2 to K, chosen per step).
pub fn parse_pairs_per_step(s: &str) -> Option<PairsPerStep> {
    match s.split_once('-') {
        None => s.trim().parse().ok().map(PairsPerStep::exactly),
        Some((lo, hi)) => {
            let (lo, hi) = (lo.trim().parse().ok()?, hi.trim().parse().ok()?);
            Some(PairsPerStep { min: lo, max: hi })
        }
    }
}

/// The pairs per step a model takes when none are given: the paper's 2 for the pivot model,
/// any of 2 to 4 chosen per step for the dynamic model (and coils for the coil-set model).
pub fn default_pairs_per_step(model: StepModel) -> PairsPerStep {
    match model {
        StepModel::Pivot => PairsPerStep::exactly(2),
        StepModel::Dynamic | StepModel::Coils => PairsPerStep::up_to(4),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relay_section_is_checked() {
        let e = Scenario::from_toml("[relay]\nmax_coils_on = 0\n", Path::new("s.toml"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("s.toml") && e.contains("`relay.max_coils_on`"),
            "{e}"
        );
    }
}
