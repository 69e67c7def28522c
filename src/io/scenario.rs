//! Scenario files (TOML): which motor (rotor and stator packings, magnet wells), which body and
//! damping, how to settle. Unknown keys are rejected; every value is checked, and an error names
//! the file, the field and what was expected. Every section has defaults (the prototype).

use crate::error::{printable, shown, Error, Result};
use crate::model::geometry::{orientation_from_xyzw, unit, Degrees, Pair, Radians, UnitVec};
use crate::model::packing::{self, Cap, Packing, SemiRegular};
use crate::model::symmetry::Group;
use crate::physics::dynamics::{Body, Method, SettleParams};
use crate::physics::magnetics::{
    disc_volume, magnet_moment_from_remanence, DipoleParts, DipoleWell,
};
use crate::physics::torque::{Interaction, MagnetTorques, TorqueTable, Well, WellShape};
use crate::planning::commutation::{
    default_step_model, Motor, PairsPerStep, StepLimits, StepModel,
};
use crate::planning::planner::{
    target_angle, PlanSettings, Scheme, DEFAULT_SETTLES_PER_STATE, DEFAULT_SETTLE_BUDGET,
};
use nalgebra::UnitQuaternion;
use nalgebra::Vector3;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Defaults of the `[magnets]` section (see the README and scenarios/prototype.toml).
pub const DEFAULT_STRENGTH_J: f64 = 0.25;
pub const DEFAULT_WIDTH_DEG: f64 = 10.0;
pub const DEFAULT_MAX_ATTRACTION_DEG: f64 = 30.0;
/// The radius of the magnets' centres (m) of shape = "dipole" when not given: the prototype's
/// 12 inch ball.
pub const DEFAULT_BALL_RADIUS_M: f64 = 0.1524;
/// Two magnets (or two coils) closer than this (chord of the unit sphere, about 6e-5 degrees)
/// are the same place: refused.
pub const COINCIDENT_TOL: f64 = 1e-6;
/// Defaults of the `[body]` section.
pub const DEFAULT_INERTIA_KG_M2: f64 = 0.023;
pub const DEFAULT_DAMPING_NMS: f64 = 1.0;

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawScenario {
    name: Option<String>,
    description: Option<String>,
    rotor: Option<RawPacking>,
    stator: Option<RawPacking>,
    magnets: Option<RawMagnets>,
    body: Option<RawBody>,
    settle: Option<RawSettle>,
    plan: Option<RawPlan>,
    sweep: Option<RawSweep>,
    relay: Option<crate::relay::RelayConfig>,
    report: Option<RawReport>,
    sensor: Option<super::sensor_section::RawSensor>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawReport {
    reference_deg: Option<f64>,
    reference_label: Option<String>,
}

/// The `[report]` section: what the pictures compare against.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReportSettings {
    /// A reference axis error (e.g. the paper's bound), drawn as a line, degrees.
    pub reference_deg: Option<f64>,
    pub reference_label: Option<String>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSweep {
    axes: Option<AxesSpec>,
    axis_count: Option<usize>,
    angles_deg: Option<Vec<f64>>,
    schemes: Option<Vec<String>>,
    models: Option<Vec<String>>,
    keep_plans: Option<bool>,
}

#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum AxesSpec {
    Named(String),
    List(Vec<[f64; 3]>),
}

/// A sweep: many planning cases from one scenario (axes x angles x schemes x models).
#[derive(Debug, Clone, PartialEq)]
pub struct Sweep {
    pub axes: Vec<UnitVec>,
    pub angles: Vec<Radians>,
    pub schemes: Vec<Scheme>,
    /// (model, pairs per step)
    pub models: Vec<(StepModel, PairsPerStep)>,
    /// Also write each case's plan CSV.
    pub keep_plans: bool,
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

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPlan {
    axis: Option<[f64; 3]>,
    angle_deg: Option<f64>,
    scheme: Option<String>,
    model: Option<StepModel>,
    pairs_per_step: Option<usize>,
    max_pairs_per_step: Option<usize>,
    settle_budget: Option<usize>,
    settles_per_state: Option<usize>,
    start: Option<[f64; 4]>,
    max_steps: Option<usize>,
    beam_width: Option<usize>,
    max_step_axis_error_deg: Option<f64>,
    min_step_angle_deg: Option<f64>,
    error_bound_start_deg: Option<f64>,
    search_bound_deg: Option<f64>,
    capture_deg: Option<f64>,
    max_coils_on: Option<usize>,
    max_candidates: Option<usize>,
    angle_tolerance_deg: Option<f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPacking {
    preset: Option<String>,
    points: Option<Vec<[f64; 3]>>,
    file: Option<String>,
    group: Option<Group>,
    generators: Option<Vec<[f64; 3]>>,
    cap_axis: Option<[f64; 3]>,
    cap_deg: Option<f64>,
}

#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
enum Shape {
    Gaussian,
    Cosine,
    Table,
    Dipole,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMagnets {
    shape: Option<Shape>,
    strength_j: Option<f64>,
    width_deg: Option<f64>,
    max_attraction_deg: Option<f64>,
    table: Option<String>,
    interaction: Option<Interaction>,
    // shape = "dipole": the physical parts (SI units)
    ball_radius_m: Option<f64>,
    magnet_moment_am2: Option<f64>,
    remanence_t: Option<f64>,
    magnet_volume_m3: Option<f64>,
    magnet_diameter_m: Option<f64>,
    magnet_thickness_m: Option<f64>,
    coil_turns: Option<f64>,
    coil_current_a: Option<f64>,
    coil_ampere_turns: Option<f64>,
    coil_radius_m: Option<f64>,
    gap_m: Option<f64>,
    core_gain: Option<f64>,
}

impl RawMagnets {
    /// The dipole keys given, by name (refused unless shape = "dipole").
    fn dipole_keys(&self) -> Vec<&'static str> {
        [
            ("ball_radius_m", self.ball_radius_m),
            ("magnet_moment_am2", self.magnet_moment_am2),
            ("remanence_t", self.remanence_t),
            ("magnet_volume_m3", self.magnet_volume_m3),
            ("magnet_diameter_m", self.magnet_diameter_m),
            ("magnet_thickness_m", self.magnet_thickness_m),
            ("coil_turns", self.coil_turns),
            ("coil_current_a", self.coil_current_a),
            ("coil_ampere_turns", self.coil_ampere_turns),
            ("coil_radius_m", self.coil_radius_m),
            ("gap_m", self.gap_m),
            ("core_gain", self.core_gain),
        ]
        .into_iter()
        .filter(|(_, v)| v.is_some())
        .map(|(k, _)| k)
        .collect()
    }
}

#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum Inertia {
    Scalar(f64),
    Diagonal([f64; 3]),
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBody {
    inertia_kg_m2: Option<Inertia>,
    damping_nms: Option<f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSettle {
    omega_tol: Option<f64>,
    torque_tol: Option<f64>,
    t_max_s: Option<f64>,
    rtol: Option<f64>,
    atol: Option<f64>,
    method: Option<Method>,
}

/// A checked scenario: the motor, the body and the settle settings.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// The file it came from (`<built-in>` for the prototype).
    pub path: PathBuf,
    /// The files it was read from: `path` (when loaded from it) and the files it names
    /// (point files, a torque table), as they were opened; what an output must not replace.
    pub files: Vec<PathBuf>,
    pub name: String,
    pub description: String,
    pub rotor: Packing,
    pub stator: Packing,
    pub torques: MagnetTorques,
    pub body: Body,
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
    pub sensor: super::sensor_section::SensorSettings,
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
    pub fn load(path: &Path) -> Result<Scenario> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
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
            sensor: super::sensor_section::check(raw.sensor, path)?,
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

/// Parses `x,y,z` into a unit vector (normalised; zero and NaN refused).
pub fn parse_axis(text: &str, arg: &str) -> Result<UnitVec> {
    let v = parse_numbers::<3>(text, arg, "x,y,z")?;
    unit(Vector3::new(v[0], v[1], v[2])).ok_or_else(|| Error::Arg {
        arg: arg.into(),
        expected: format!("a non-zero, finite vector x,y,z, got '{text}'"),
    })
}

/// Parses `qx,qy,qz,qw` into an orientation (normalised; zero and NaN refused).
pub fn parse_orientation(text: &str, arg: &str) -> Result<crate::model::geometry::Orientation> {
    let v = parse_numbers::<4>(text, arg, "qx,qy,qz,qw")?;
    crate::model::geometry::orientation_from_xyzw(v[0], v[1], v[2], v[3]).ok_or_else(|| {
        Error::Arg {
            arg: arg.into(),
            expected: format!("a non-zero, finite quaternion qx,qy,qz,qw, got '{text}'"),
        }
    })
}

fn parse_numbers<const N: usize>(text: &str, arg: &str, form: &str) -> Result<[f64; N]> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let bad = || Error::Arg {
        arg: arg.into(),
        expected: format!("{N} numbers {form}, got '{text}'"),
    };
    if parts.len() != N {
        return Err(bad());
    }
    let mut out = [0.0; N];
    for (o, p) in out.iter_mut().zip(&parts) {
        *o = p.parse::<f64>().map_err(|_| bad())?;
    }
    Ok(out)
}

/// Field checks with the file name at hand.
struct Checker<'a> {
    file: &'a Path,
    /// The files read so far (point files, tables).
    read: std::cell::RefCell<Vec<PathBuf>>,
}

impl Checker<'_> {
    fn err(&self, field: &str, expected: impl Into<String>) -> Error {
        Error::field(self.file, field, expected)
    }

    fn positive(&self, field: &str, v: Option<f64>, default: f64) -> Result<f64> {
        match v {
            None => Ok(default),
            Some(x) if x.is_finite() && x > 0.0 => Ok(x),
            Some(x) => Err(self.err(field, format!("a finite number > 0, got {}", shown(x)))),
        }
    }

    fn non_negative(&self, field: &str, v: Option<f64>, default: f64) -> Result<f64> {
        match v {
            None => Ok(default),
            Some(x) if x.is_finite() && x >= 0.0 => Ok(x),
            Some(x) => Err(self.err(field, format!("a finite number >= 0, got {}", shown(x)))),
        }
    }

    fn unit(&self, field: &str, v: [f64; 3]) -> Result<UnitVec> {
        unit(Vector3::new(v[0], v[1], v[2])).ok_or_else(|| {
            self.err(
                field,
                format!(
                    "a non-zero, finite vector, got [{}, {}, {}]",
                    shown(v[0]),
                    shown(v[1]),
                    shown(v[2])
                ),
            )
        })
    }

    fn relative(&self, p: &str) -> PathBuf {
        let p = Path::new(p);
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.file
                .parent()
                .map(|d| d.join(p))
                .unwrap_or_else(|| p.to_path_buf())
        }
    }

    /// A packing given as the orbit of generator points under a symmetry group, optionally
    /// cut to a spherical cap.
    fn group_packing(
        &self,
        group: Group,
        generators: Option<Vec<[f64; 3]>>,
        cap_axis: Option<[f64; 3]>,
        cap_deg: Option<f64>,
        section: &str,
    ) -> Result<Packing> {
        let gens = generators.ok_or_else(|| {
            self.err(
                &format!("{section}.generators"),
                "a list of generator points [[x, y, z], ...] for the group",
            )
        })?;
        let mut generator_points = Vec::new();
        for (i, g) in gens.iter().enumerate() {
            generator_points.push(self.unit(&format!("{section}.generators[{i}]"), *g)?);
        }
        let cap = match cap_deg {
            None => None,
            Some(deg) => {
                if !(deg.is_finite() && deg > 0.0 && deg <= 180.0) {
                    return Err(self.err(
                        &format!("{section}.cap_deg"),
                        format!("an angle in (0, 180] degrees, got {}", shown(deg)),
                    ));
                }
                let axis = self.unit(
                    &format!("{section}.cap_axis"),
                    cap_axis.unwrap_or([0.0, 0.0, -1.0]),
                )?;
                Some(Cap {
                    center: axis,
                    radius: Degrees(deg).to_radians(),
                })
            }
        };
        Ok(SemiRegular {
            group,
            generators: generator_points,
            cap,
        }
        .points())
    }

    /// An error unless the packing's points are distinct (named by where they came from).
    fn check_distinct(&self, pk: &Packing, section: &str, given_flags: &[bool; 4]) -> Result<()> {
        if let Some((a, b)) = pk.coincident(COINCIDENT_TOL) {
            let what = if section == "rotor" {
                "magnets"
            } else {
                "coils"
            };
            let source = ["preset", "points", "file", "group"]
                .iter()
                .zip(given_flags)
                .find(|(_, g)| **g)
                .map_or("preset", |(n, _)| n);
            return Err(self.err(
                &format!("{section}.{source}"),
                format!(
                    "distinct {what}, got {what} {a} and {b} at the same place ({:.2e} deg apart)",
                    crate::model::geometry::angular_distance(&pk.points[a], &pk.points[b])
                        .0
                        .to_degrees()
                ),
            ));
        }
        Ok(())
    }

    fn packing(&self, raw: RawPacking, section: &str) -> Result<Packing> {
        let given_flags = [
            raw.preset.is_some(),
            raw.points.is_some(),
            raw.file.is_some(),
            raw.group.is_some(),
        ];
        let given = given_flags.iter().filter(|b| **b).count();
        if given > 1 {
            return Err(self.err(
                section,
                "only one of preset, points, file or group (+ generators)",
            ));
        }
        if raw.generators.is_some() && raw.group.is_none() {
            return Err(self.err(&format!("{section}.generators"), "a `group` beside them"));
        }
        if (raw.cap_axis.is_some() || raw.cap_deg.is_some()) && raw.group.is_none() {
            return Err(self.err(&format!("{section}.cap_deg"), "a `group` beside it"));
        }
        let pk = if let Some(points) = raw.points {
            let mut pts = Vec::with_capacity(points.len());
            for (i, p) in points.iter().enumerate() {
                pts.push(self.unit(&format!("{section}.points[{i}]"), *p)?);
            }
            Packing { points: pts }
        } else if let Some(file) = raw.file {
            let path = self.relative(&file);
            let text = std::fs::read_to_string(&path).map_err(|e| {
                self.err(
                    &format!("{section}.file"),
                    format!(
                        "a readable CSV of x,y,z unit vectors, got {}: {e}",
                        path.display()
                    ),
                )
            })?;
            self.read.borrow_mut().push(path.clone());
            packing::parse_points_csv(&text).map_err(|m| {
                self.err(
                    &format!("{section}.file"),
                    format!("a CSV of x,y,z unit vectors in {}: {m}", path.display()),
                )
            })?
        } else if let Some(group) = raw.group {
            self.group_packing(group, raw.generators, raw.cap_axis, raw.cap_deg, section)?
        } else {
            match raw.preset.as_deref().unwrap_or("prototype") {
                "prototype" if section == "rotor" => packing::prototype_rotor(),
                "prototype" => packing::prototype_stator(),
                other => {
                    return Err(self.err(
                        &format!("{section}.preset"),
                        format!("\"prototype\" (the only preset), got \"{other}\""),
                    ))
                }
            }
        };
        if pk.is_empty() {
            return Err(self.err(section, "at least one point"));
        }
        self.check_distinct(&pk, section, &given_flags)?;
        Ok(pk)
    }

    fn magnets(&self, raw: RawMagnets) -> Result<(Well, Interaction)> {
        let shape = raw.shape.unwrap_or(Shape::Gaussian);
        let max_deg = raw.max_attraction_deg.unwrap_or(DEFAULT_MAX_ATTRACTION_DEG);
        if !(max_deg.is_finite() && max_deg > 0.0 && max_deg <= 180.0) {
            return Err(self.err(
                "magnets.max_attraction_deg",
                format!("an angle in (0, 180] degrees, got {}", shown(max_deg)),
            ));
        }
        let strength = self.positive("magnets.strength_j", raw.strength_j, DEFAULT_STRENGTH_J)?;
        if shape != Shape::Table && raw.table.is_some() {
            return Err(self.err("magnets.table", "no table unless shape = \"table\""));
        }
        if let Some(k) = raw.dipole_keys().first().filter(|_| shape != Shape::Dipole) {
            return Err(self.err(
                &format!("magnets.{k}"),
                "no physical parts unless shape = \"dipole\"",
            ));
        }
        let shape = match shape {
            Shape::Gaussian => {
                let w = self.positive("magnets.width_deg", raw.width_deg, DEFAULT_WIDTH_DEG)?;
                WellShape::Gaussian {
                    strength_j: strength,
                    width: Degrees(w).to_radians(),
                }
            }
            Shape::Cosine => WellShape::Cosine {
                strength_j: strength,
            },
            Shape::Dipole => return self.dipole_magnets(&raw),
            Shape::Table => {
                let file = raw.table.ok_or_else(|| {
                    self.err(
                        "magnets.table",
                        "a path to a CSV of angle_deg,torque_nm rows when shape = \"table\"",
                    )
                })?;
                let path = self.relative(&file);
                self.read.borrow_mut().push(path.clone());
                WellShape::Table(read_table(&path).map_err(|m| {
                    self.err(
                        "magnets.table",
                        format!("a torque curve in {}: {m}", path.display()),
                    )
                })?)
            }
        };
        Ok((
            Well::new(shape, Degrees(max_deg).to_radians()),
            raw.interaction.unwrap_or_default(),
        ))
    }

    /// shape = "dipole": the parts, the well they make (attracting out to where its pull
    /// ends, unless `max_attraction_deg` says otherwise) and the interaction ("coils" unless
    /// given: every energised coil acts on every magnet).
    fn dipole_magnets(&self, raw: &RawMagnets) -> Result<(Well, Interaction)> {
        for (k, v) in [("strength_j", raw.strength_j), ("width_deg", raw.width_deg)] {
            if v.is_some() {
                return Err(self.err(
                    &format!("magnets.{k}"),
                    "no well strength or width with shape = \"dipole\" (the parts make the well)",
                ));
            }
        }
        let parts = self.dipole_parts(raw)?;
        let well = DipoleWell::new(parts).map_err(|m| self.dipole_err(&m))?;
        let max = match raw.max_attraction_deg {
            // where the pull ends (g falls to 0): beyond, the coil repels weakly
            None => Radians(well.reach(0.0)),
            Some(d) => Degrees(d).to_radians(),
        };
        Ok((
            Well::new(WellShape::Dipole(well), max),
            raw.interaction.unwrap_or(Interaction::Coils),
        ))
    }

    /// A message of `magnetics` ("field: expected ...") as a scenario error on `magnets.field`.
    fn dipole_err(&self, m: &str) -> Error {
        match m.split_once(": expected ") {
            Some((field, rest)) if !field.contains(' ') => {
                // the parts' ampere-turns are the scenario's coil_ampere_turns (or turns x current)
                let field = field.replace("coil_turns_amps", "coil_ampere_turns");
                self.err(&format!("magnets.{field}"), rest.to_string())
            }
            _ => self.err("magnets", m.to_string()),
        }
    }

    /// The physical parts of shape = "dipole": the magnet by its moment, or by its remanence
    /// and volume (or disc diameter and thickness); the coil by its ampere-turns, or turns and
    /// current; the ball's radius (default the prototype's) and the core's gain (default 1).
    fn dipole_parts(&self, raw: &RawMagnets) -> Result<DipoleParts> {
        let required = |k: &str, v: Option<f64>, what: &str| {
            let field = format!("magnets.{k}");
            match v {
                None => Err(self.err(&field, format!("{what} when shape = \"dipole\""))),
                Some(x) => self.positive(&field, Some(x), 0.0),
            }
        };
        // a product of valid values may still overflow (or vanish): named by what was given
        let finite = |field: &str, what: &str, v: f64, parts: String| {
            if v.is_finite() && v > 0.0 {
                Ok(v)
            } else {
                Err(self.err(
                    field,
                    format!(
                        "a magnet whose {what} is a finite number > 0, got {} from {parts}",
                        crate::error::shown(v)
                    ),
                ))
            }
        };
        let moment = match (raw.magnet_moment_am2, raw.remanence_t) {
            (Some(m), None) => self.positive("magnets.magnet_moment_am2", Some(m), 0.0)?,
            (None, Some(br)) => {
                let br = self.positive("magnets.remanence_t", Some(br), 0.0)?;
                let (volume, size) = match raw.magnet_volume_m3 {
                    Some(v) => (
                        self.positive("magnets.magnet_volume_m3", Some(v), 0.0)?,
                        "magnets.magnet_volume_m3",
                    ),
                    None => {
                        let d = required("magnet_diameter_m", raw.magnet_diameter_m, "a disc's diameter (m), or magnet_volume_m3,")?;
                        let t = required("magnet_thickness_m", raw.magnet_thickness_m, "a disc's thickness (m), or magnet_volume_m3,")?;
                        let v = finite(
                            "magnets.magnet_diameter_m",
                            "volume (m^3)",
                            disc_volume(d, t),
                            format!(
                                "magnet_diameter_m = {} and magnet_thickness_m = {}",
                                crate::error::shown(d),
                                crate::error::shown(t)
                            ),
                        )?;
                        (v, "magnets.magnet_diameter_m")
                    }
                };
                finite(
                    size,
                    "moment Br V / mu0 (A m^2)",
                    magnet_moment_from_remanence(br, volume),
                    format!(
                        "remanence_t = {} and a volume of {} m^3",
                        crate::error::shown(br),
                        crate::error::shown(volume)
                    ),
                )?
            }
            (Some(_), Some(_)) => {
                return Err(self.err(
                    "magnets.magnet_moment_am2",
                    "either the moment or remanence_t (with the magnet's size), not both",
                ))
            }
            (None, None) => {
                return Err(self.err(
                    "magnets.magnet_moment_am2",
                    "the magnet's moment (A m^2), or remanence_t (T) with its size, when shape = \"dipole\"",
                ))
            }
        };
        let turns_amps = match (raw.coil_ampere_turns, raw.coil_turns, raw.coil_current_a) {
            (Some(ni), None, None) => ni,
            (None, Some(n), Some(i)) => {
                let n = self.positive("magnets.coil_turns", Some(n), 0.0)?;
                if !(i.is_finite() && i > 0.0) {
                    return Err(self.err(
                        "magnets.coil_current_a",
                        format!(
                            "a finite current > 0 (A; a well is a coil that attracts), got {}",
                            crate::error::shown(i)
                        ),
                    ));
                }
                let ni = n * i;
                if !(ni.is_finite() && ni > 0.0) {
                    return Err(self.err(
                        "magnets.coil_turns",
                        format!(
                            "coil_turns x coil_current_a finite and > 0, got {} x {} A = {} A",
                            crate::error::shown(n),
                            crate::error::shown(i),
                            crate::error::shown(ni)
                        ),
                    ));
                }
                ni
            }
            _ => {
                return Err(self.err(
                    "magnets.coil_ampere_turns",
                    "the coil's ampere-turns (A), or coil_turns and coil_current_a, when \
                     shape = \"dipole\"",
                ))
            }
        };
        let parts =
            DipoleParts {
                ball_radius_m: self.positive(
                    "magnets.ball_radius_m",
                    raw.ball_radius_m,
                    DEFAULT_BALL_RADIUS_M,
                )?,
                magnet_moment_am2: moment,
                coil_turns_amps: turns_amps,
                coil_radius_m: required(
                    "coil_radius_m",
                    raw.coil_radius_m,
                    "the mean radius of a coil's winding (m)",
                )?,
                gap_m: match raw.gap_m {
                    None => return Err(self.err(
                        "magnets.gap_m",
                        "the distance (m) from the magnets' centres (at ball_radius_m) out to a \
                         coil's loop when shape = \"dipole\"",
                    )),
                    Some(g) => self.non_negative("magnets.gap_m", Some(g), 0.0)?,
                },
                core_gain: raw.core_gain.unwrap_or(1.0),
            };
        parts.validate().map_err(|m| self.dipole_err(&m))?;
        Ok(parts)
    }

    fn body(&self, raw: RawBody) -> Result<Body> {
        let inertia = match raw.inertia_kg_m2 {
            None => Vector3::repeat(DEFAULT_INERTIA_KG_M2),
            Some(Inertia::Scalar(x)) => {
                Vector3::repeat(self.positive("body.inertia_kg_m2", Some(x), 0.0)?)
            }
            Some(Inertia::Diagonal(d)) => {
                let mut v = Vector3::zeros();
                for k in 0..3 {
                    v[k] = self.positive(&format!("body.inertia_kg_m2[{k}]"), Some(d[k]), 0.0)?;
                }
                v
            }
        };
        let damping =
            self.non_negative("body.damping_nms", raw.damping_nms, DEFAULT_DAMPING_NMS)?;
        Ok(Body { inertia, damping })
    }

    /// An optional whole number >= 1 (`default` when absent).
    fn count(&self, field: &str, v: Option<usize>, default: usize) -> Result<usize> {
        match v {
            None => Ok(default),
            Some(0) => Err(self.err(field, "a whole number >= 1, got 0")),
            Some(x) => Ok(x),
        }
    }

    /// An optional angle in (0, 180] degrees (`default` when absent).
    fn small_angle(&self, field: &str, v: Option<f64>, default: Radians) -> Result<Radians> {
        match v {
            None => Ok(default),
            Some(x) if x.is_finite() && x > 0.0 && x <= 180.0 => Ok(Degrees(x).to_radians()),
            Some(x) => Err(self.err(
                field,
                format!("an angle in (0, 180] degrees, got {}", shown(x)),
            )),
        }
    }

    /// The step limits of the `[plan]` section.
    fn step_limits(
        &self,
        raw: &RawPlan,
        relay: &crate::relay::RelaySettings,
    ) -> Result<StepLimits> {
        let d = StepLimits::default();
        let count = |field: &str, v: Option<usize>, default: usize| self.count(field, v, default);
        let angle_field =
            |field: &str, v: Option<f64>, default: Radians| self.small_angle(field, v, default);
        Ok(StepLimits {
            min_angle: angle_field(
                "plan.min_step_angle_deg",
                raw.min_step_angle_deg,
                d.min_angle,
            )?,
            max_axis_error: angle_field(
                "plan.max_step_axis_error_deg",
                raw.max_step_axis_error_deg,
                d.max_axis_error,
            )?,
            bound_start: angle_field(
                "plan.error_bound_start_deg",
                raw.error_bound_start_deg,
                d.bound_start,
            )?,
            max_candidates: count("plan.max_candidates", raw.max_candidates, d.max_candidates)?,
            max_coils_on: count("plan.max_coils_on", raw.max_coils_on, relay.max_coils_on)?,
            on_time: Some(relay.on_time_limit()),
            capture: match raw.capture_deg {
                None => None,
                Some(_) => Some(angle_field(
                    "plan.capture_deg",
                    raw.capture_deg,
                    Radians(0.0),
                )?),
            },
            search_bound: angle_field(
                "plan.search_bound_deg",
                raw.search_bound_deg,
                d.search_bound,
            )?,
        })
    }

    /// The `[plan]` section; without `model`, the motor's physics chooses
    /// ([`default_step_model`]).
    /// `relay`: the scenario's `[relay]` section, whose limits the plans keep to (its
    /// `max_coils_on` unless `plan.max_coils_on` is given, and its on-time limit).
    fn plan(
        &self,
        raw: RawPlan,
        torques: &MagnetTorques,
        relay: &crate::relay::RelaySettings,
    ) -> Result<PlanSettings> {
        let axis = self.unit("plan.axis", raw.axis.unwrap_or([0.0, 0.0, 1.0]))?;
        let angle = target_angle(raw.angle_deg.unwrap_or(90.0))
            .map_err(|m| self.err("plan.angle_deg", m))?;
        let scheme = match raw.scheme.as_deref() {
            None => Scheme::Search,
            Some(n) => Scheme::parse(n).map_err(|m| self.err("plan.scheme", m))?,
        };
        let model = raw.model.unwrap_or_else(|| default_step_model(torques));
        let (pairs, field) =
            match (raw.pairs_per_step, raw.max_pairs_per_step) {
                (Some(_), Some(_)) => return Err(self.err(
                    "plan.max_pairs_per_step",
                    "either pairs_per_step (exactly K) or max_pairs_per_step (2 to K), not both",
                )),
                (Some(k), None) => (PairsPerStep::exactly(k), "plan.pairs_per_step"),
                (None, Some(k)) => (PairsPerStep::up_to(k), "plan.max_pairs_per_step"),
                (None, None) => (default_pairs_per_step(model), "plan.model"),
            };
        check_pairs_per_step(model, pairs).map_err(|m| self.err(field, m))?;
        let start = match raw.start {
            None => UnitQuaternion::identity(),
            Some(v) => orientation_from_xyzw(v[0], v[1], v[2], v[3]).ok_or_else(|| {
                self.err(
                    "plan.start",
                    "a non-zero, finite quaternion [qx, qy, qz, qw]",
                )
            })?,
        };
        let count = |field: &str, v: Option<usize>, default: usize| self.count(field, v, default);
        let angle_field =
            |field: &str, v: Option<f64>, default: Radians| self.small_angle(field, v, default);
        let limits = self.step_limits(&raw, relay)?;
        let supply_field = match (raw.pairs_per_step, raw.max_pairs_per_step) {
            (None, None) => "plan.max_coils_on",
            _ => field,
        };
        check_supply(pairs, limits.max_coils_on).map_err(|m| self.err(supply_field, m))?;
        Ok(PlanSettings {
            axis,
            angle,
            scheme,
            model,
            pairs,
            start,
            limits,
            max_steps: count("plan.max_steps", raw.max_steps, 200)?,
            beam_width: count("plan.beam_width", raw.beam_width, 24)?,
            settle_budget: count(
                "plan.settle_budget",
                raw.settle_budget,
                DEFAULT_SETTLE_BUDGET,
            )?,
            settles_per_state: count(
                "plan.settles_per_state",
                raw.settles_per_state,
                DEFAULT_SETTLES_PER_STATE,
            )?,
            angle_tolerance: angle_field(
                "plan.angle_tolerance_deg",
                raw.angle_tolerance_deg,
                Degrees(0.5).to_radians(),
            )?,
        })
    }

    fn sweep(&self, raw: RawSweep, plan: &PlanSettings) -> Result<Sweep> {
        let axes = match (raw.axes, raw.axis_count) {
            (None, None) => vec![plan.axis],
            (Some(AxesSpec::Named(n)), count) if n == "sphere" => {
                let c = count.unwrap_or(500);
                if c == 0 || c > 100_000 {
                    return Err(self.err(
                        "sweep.axis_count",
                        format!("a number of axes from 1 to 100000, got {c}"),
                    ));
                }
                sphere_axes(c)
            }
            (Some(AxesSpec::Named(n)), _) => {
                return Err(self.err(
                    "sweep.axes",
                    format!("\"sphere\" or a list of [x, y, z] axes, got \"{n}\""),
                ))
            }
            (Some(AxesSpec::List(list)), None) => {
                self.sweep_list("axes", "axis", Some(list), vec![], |f, a| self.unit(f, *a))?
            }
            (None, Some(_)) | (Some(AxesSpec::List(_)), Some(_)) => {
                return Err(self.err("sweep.axis_count", "axes = \"sphere\" beside it"))
            }
        };
        let angles = self.sweep_list(
            "angles_deg",
            "angle",
            raw.angles_deg,
            vec![plan.angle],
            |f, a| target_angle(*a).map_err(|m| self.err(f, m)),
        )?;
        let schemes = self.sweep_list(
            "schemes",
            "scheme",
            raw.schemes,
            vec![plan.scheme],
            |f, n| Scheme::parse(n).map_err(|m| self.err(f, m)),
        )?;
        let models = self.sweep_list(
            "models",
            "model",
            raw.models,
            vec![(plan.model, plan.pairs)],
            |f, n| {
                let m = self.sweep_model(f, n)?;
                check_supply(m.1, plan.limits.max_coils_on).map_err(|e| self.err(f, e))?;
                Ok(m)
            },
        )?;
        Ok(Sweep {
            axes,
            angles,
            schemes,
            models,
            keep_plans: raw.keep_plans.unwrap_or(false),
        })
    }

    /// A list of `[sweep]`: `default` when absent, an error when empty (`what` names an entry),
    /// else each entry checked by `each`, which is given the entry's field name.
    fn sweep_list<R, T>(
        &self,
        name: &str,
        what: &str,
        raw: Option<Vec<R>>,
        default: Vec<T>,
        each: impl Fn(&str, &R) -> Result<T>,
    ) -> Result<Vec<T>> {
        match raw {
            None => Ok(default),
            Some(list) if list.is_empty() => {
                Err(self.err(&format!("sweep.{name}"), format!("at least one {what}")))
            }
            Some(list) => list
                .iter()
                .enumerate()
                .map(|(i, r)| each(&format!("sweep.{name}[{i}]"), r))
                .collect(),
        }
    }

    /// One entry of `sweep.models`: a model name, or `dynamic:K` / `dynamic:2-K`.
    fn sweep_model(&self, field: &str, n: &str) -> Result<(StepModel, PairsPerStep)> {
        let bad = || {
            self.err(
                field,
                format!(
                    "\"pivot\", \"dynamic\", \"dynamic:K\" (exactly K pairs per \
                     step), \"dynamic:2-K\" (2 to K), \"coils\" or \"coils:2-K\" (2 to K \
                     coils on), got \"{n}\""
                ),
            )
        };
        let m = match n.split_once(':') {
            // a pair model alone: 2 pairs per step; coil sets alone: their default, 2 to 4 coils
            None => StepModel::from_name(n)
                .map(|m| match m {
                    StepModel::Coils => (m, default_pairs_per_step(m)),
                    _ => (m, PairsPerStep::exactly(2)),
                })
                .ok_or_else(bad)?,
            Some(("dynamic", k)) => (StepModel::Dynamic, parse_pairs_per_step(k).ok_or_else(bad)?),
            Some(("coils", k)) => (StepModel::Coils, parse_pairs_per_step(k).ok_or_else(bad)?),
            _ => return Err(bad()),
        };
        check_pairs_per_step(m.0, m.1).map_err(|e| self.err(field, e))?;
        Ok(m)
    }

    /// The settle test holds wherever the torque is below `settle.torque_tol`: a well whose
    /// strongest torque is below it would hold the ball anywhere at t = 0, so such a scenario
    /// is refused, naming what makes the well (`strength_j`, the table, the parts).
    fn well_scale(&self, well: &Well, settle: &SettleParams) -> Result<()> {
        let peak = well.peak_torque();
        if peak.is_finite() && peak > settle.torque_tol {
            return Ok(());
        }
        let field = match well.shape() {
            WellShape::Gaussian { .. } | WellShape::Cosine { .. } => "magnets.strength_j",
            WellShape::Table(_) => "magnets.table",
            WellShape::Dipole(_) => "magnets",
        };
        Err(self.err(
            field,
            format!(
                "a well whose strongest torque (one coil on one magnet, within the cut-off) \
                 is above settle.torque_tol = {} N m, got {} N m: weaker, every orientation \
                 would pass the settle test at once and count as held",
                crate::error::shown(settle.torque_tol),
                crate::error::shown(peak)
            ),
        ))
    }

    fn settle(&self, raw: RawSettle) -> Result<SettleParams> {
        let d = SettleParams::default();
        Ok(SettleParams {
            omega_tol: self.positive("settle.omega_tol", raw.omega_tol, d.omega_tol)?,
            torque_tol: self.positive("settle.torque_tol", raw.torque_tol, d.torque_tol)?,
            t_max: self.positive("settle.t_max_s", raw.t_max_s, d.t_max)?,
            rtol: self.positive("settle.rtol", raw.rtol, d.rtol)?,
            atol: self.positive("settle.atol", raw.atol, d.atol)?,
            method: raw.method.unwrap_or(d.method),
            follow_unheld: d.follow_unheld,
        })
    }
}

/// Reads a torque table CSV: header `angle_deg,torque_nm` (required), then rows.
fn read_table(path: &Path) -> std::result::Result<TorqueTable, String> {
    let mut rdr = csv::Reader::from_path(path).map_err(|e| e.to_string())?;
    let headers = rdr.headers().map_err(|e| format!("line 1: {e}"))?.clone();
    packing::check_header(&headers, &["angle_deg", "torque_nm"], "row")?;
    let mut rows = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| format!("line {}: {e}", packing::csv_line(e.position())))?;
        let line = packing::csv_line(rec.position());
        if rec.len() != 2 {
            return Err(format!(
                "line {line}: expected 2 columns angle_deg,torque_nm"
            ));
        }
        let num = |k: usize| {
            rec[k]
                .trim()
                .parse::<f64>()
                .map_err(|_| format!("line {line}: '{}' is not a number", &rec[k]))
        };
        rows.push((num(0)?, num(1)?));
    }
    TorqueTable::from_rows(&rows)
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
