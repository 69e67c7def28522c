//! The checks that turn a scenario file as written (`raw`) into a [`super::Scenario`]: every
//! value in range, every file it names read, each error naming the file, the field and what was
//! expected.

use super::raw::*;
use super::*;
use crate::error::{Error, Result};
use crate::model::geometry::{orientation_from_xyzw, unit, Degrees, Orientation, Radians, UnitVec};
use crate::model::packing::{self, Cap, Packing, SemiRegular};
use crate::model::symmetry::Group;
use crate::physics::dynamics::{Body, SettleParams};
use crate::physics::torque::{Interaction, MagnetTorques, TorqueTable, Well, WellShape};
use crate::planning::commutation::{default_step_model, PairsPerStep, StepLimits, StepModel};
use crate::planning::planner::{
    target_angle, PlanSettings, Scheme, DEFAULT_SETTLES_PER_STATE, DEFAULT_SETTLE_BUDGET,
    DEFAULT_STALL_SETTLES,
};
use crate::text::shown;
use nalgebra::UnitQuaternion;
use nalgebra::Vector3;
use std::path::{Path, PathBuf};

/// Field checks with the file name at hand.
pub(super) struct Checker<'a> {
    pub(super) file: &'a Path,
    /// The files read so far (point files, tables).
    pub(super) read: std::cell::RefCell<Vec<PathBuf>>,
}

impl Checker<'_> {
    pub(super) fn err(&self, field: &str, expected: impl Into<String>) -> Error {
        Error::field(self.file, field, expected)
    }

    pub(super) fn positive(&self, field: &str, v: Option<f64>, default: f64) -> Result<f64> {
        match v {
            None => Ok(default),
            Some(x) if x.is_finite() && x > 0.0 => Ok(x),
            Some(x) => Err(self.err(field, format!("a finite number > 0, got {}", shown(x)))),
        }
    }

    pub(super) fn non_negative(&self, field: &str, v: Option<f64>, default: f64) -> Result<f64> {
        match v {
            None => Ok(default),
            Some(x) if x.is_finite() && x >= 0.0 => Ok(x),
            Some(x) => Err(self.err(field, format!("a finite number >= 0, got {}", shown(x)))),
        }
    }

    pub(super) fn unit(&self, field: &str, v: [f64; 3]) -> Result<UnitVec> {
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

    pub(super) fn relative(&self, p: &str) -> PathBuf {
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
    pub(super) fn group_packing(
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
    pub(super) fn check_distinct(
        &self,
        pk: &Packing,
        section: &str,
        given_flags: &[bool; 4],
    ) -> Result<()> {
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

    pub(super) fn packing(&self, raw: RawPacking, section: &str) -> Result<Packing> {
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
            let text = crate::io::input::read_text(&path).map_err(|e| {
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

    pub(super) fn magnets(&self, raw: RawMagnets) -> Result<(Well, Interaction)> {
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

    pub(super) fn body(&self, raw: RawBody) -> Result<Body> {
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
    pub(super) fn count(&self, field: &str, v: Option<usize>, default: usize) -> Result<usize> {
        match v {
            None => Ok(default),
            Some(0) => Err(self.err(field, "a whole number >= 1, got 0")),
            Some(x) => Ok(x),
        }
    }

    /// An optional angle in (0, 180] degrees (`default` when absent).
    pub(super) fn small_angle(
        &self,
        field: &str,
        v: Option<f64>,
        default: Radians,
    ) -> Result<Radians> {
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
    pub(super) fn step_limits(
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

    /// `plan.start`: the identity when absent.
    fn plan_start(&self, start: Option<[f64; 4]>) -> Result<Orientation> {
        match start {
            None => Ok(UnitQuaternion::identity()),
            Some(v) => orientation_from_xyzw(v[0], v[1], v[2], v[3]).ok_or_else(|| {
                self.err(
                    "plan.start",
                    "a non-zero, finite quaternion [qx, qy, qz, qw]",
                )
            }),
        }
    }

    /// The `[plan]` section; without `model`, the motor's physics chooses
    /// ([`default_step_model`]).
    /// `relay`: the scenario's `[relay]` section, whose limits the plans keep to (its
    /// `max_coils_on` unless `plan.max_coils_on` is given, and its on-time limit).
    pub(super) fn plan(
        &self,
        raw: RawPlan,
        torques: &MagnetTorques,
        relay: &crate::relay::RelaySettings,
    ) -> Result<PlanSettings> {
        let axis = self.unit("plan.axis", raw.axis.unwrap_or([0.0, 0.0, 1.0]))?;
        let angle = target_angle(raw.angle_deg.unwrap_or(90.0), "`plan.start`")
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
        let start = self.plan_start(raw.start)?;
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
            stall_settles: count(
                "plan.stall_settles",
                raw.stall_settles,
                DEFAULT_STALL_SETTLES,
            )?,
            angle_tolerance: angle_field(
                "plan.angle_tolerance_deg",
                raw.angle_tolerance_deg,
                Degrees(0.5).to_radians(),
            )?,
            tolerance: angle_field(
                "plan.tolerance_deg",
                raw.tolerance_deg,
                Degrees(crate::planning::plan::DEFAULT_TOLERANCE_DEG).to_radians(),
            )?,
            target: None,
        })
    }

    pub(super) fn sweep(&self, raw: RawSweep, plan: &PlanSettings) -> Result<Sweep> {
        let motions = self.motions(&raw)?;
        let axes = match (raw.axes, raw.axis_count) {
            _ if !motions.is_empty() => motions.iter().map(|m| m.axis).collect(),
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
        let angles = match motions.is_empty() {
            false => motions.iter().map(|m| m.angle).collect(),
            true => self.sweep_list(
                "angles_deg",
                "angle",
                raw.angles_deg,
                vec![plan.angle],
                |f, a| target_angle(*a, "`plan.start`").map_err(|m| self.err(f, m)),
            )?,
        };
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
            motions,
        })
    }

    /// A random-motion sweep's motions (`motions`, `seed`, `angle_min_deg`, `angle_max_deg`;
    /// none without `motions`), refused beside `axes`, `axis_count` or `angles_deg`.
    fn motions(&self, raw: &RawSweep) -> Result<Vec<Motion>> {
        let Some(count) = raw.motions else {
            for (field, given) in [
                ("sweep.seed", raw.seed.is_some()),
                ("sweep.angle_min_deg", raw.angle_min_deg.is_some()),
                ("sweep.angle_max_deg", raw.angle_max_deg.is_some()),
            ] {
                if given {
                    return Err(self.err(field, "`motions = N` beside it (a random-motion sweep)"));
                }
            }
            return Ok(Vec::new());
        };
        if count == 0 || count > 100_000 {
            return Err(self.err(
                "sweep.motions",
                format!("a number of motions from 1 to 100000, got {count}"),
            ));
        }
        for (field, given) in [
            ("sweep.axes", raw.axes.is_some()),
            ("sweep.axis_count", raw.axis_count.is_some()),
            ("sweep.angles_deg", raw.angles_deg.is_some()),
        ] {
            if given {
                return Err(self.err(
                    field,
                    "no axes or angles beside `motions` (each random motion has its own)",
                ));
            }
        }
        let angle = |field: &str, v: Option<f64>, default: f64| {
            target_angle(v.unwrap_or(default), "each motion's start")
                .map_err(|m| self.err(field, m))
        };
        let min = angle("sweep.angle_min_deg", raw.angle_min_deg, 5.0)?;
        let max = angle("sweep.angle_max_deg", raw.angle_max_deg, 180.0)?;
        if min.0 > max.0 {
            return Err(self.err(
                "sweep.angle_max_deg",
                format!(
                    "at least sweep.angle_min_deg ({} degrees), got {}",
                    shown(min.0.to_degrees()),
                    shown(max.0.to_degrees())
                ),
            ));
        }
        Ok(random_motions(count, raw.seed.unwrap_or(1), min, max))
    }

    /// A list of `[sweep]`: `default` when absent, an error when empty (`what` names an entry),
    /// else each entry checked by `each`, which is given the entry's field name.
    pub(super) fn sweep_list<R, T>(
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
    pub(super) fn sweep_model(&self, field: &str, n: &str) -> Result<(StepModel, PairsPerStep)> {
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
    pub(super) fn well_scale(&self, well: &Well, settle: &SettleParams) -> Result<()> {
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
                crate::text::shown(settle.torque_tol),
                crate::text::shown(peak)
            ),
        ))
    }

    pub(super) fn settle(&self, raw: RawSettle) -> Result<SettleParams> {
        let d = SettleParams::default();
        Ok(SettleParams {
            omega_tol: self.positive("settle.omega_tol", raw.omega_tol, d.omega_tol)?,
            torque_tol: self.positive("settle.torque_tol", raw.torque_tol, d.torque_tol)?,
            t_max: self.positive("settle.t_max_s", raw.t_max_s, d.t_max)?,
            rtol: self.positive("settle.rtol", raw.rtol, d.rtol)?,
            atol: self.positive("settle.atol", raw.atol, d.atol)?,
            method: raw.method.unwrap_or(d.method),
            follow_unheld: d.follow_unheld,
            arrival: match raw.arrival_deg {
                None => d.arrival,
                Some(x) if x.is_finite() && x > 0.0 && x <= MAX_ARRIVAL_DEG => {
                    Degrees(x).to_radians()
                }
                Some(x) => {
                    return Err(self.err(
                        "settle.arrival_deg",
                        format!(
                            "an angle in (0, {MAX_ARRIVAL_DEG}] degrees, got {}",
                            shown(x)
                        ),
                    ))
                }
            },
        })
    }
}

/// The largest `settle.arrival_deg`: beyond it a step would be cut short of its well.
const MAX_ARRIVAL_DEG: f64 = 5.0;

/// Reads a torque table CSV: header `angle_deg,torque_nm` (required), then rows.
pub(super) fn read_table(path: &Path) -> std::result::Result<TorqueTable, String> {
    let bytes = crate::io::input::read_bytes(path).map_err(|e| e.to_string())?;
    let mut rdr = csv::Reader::from_reader(bytes.as_slice());
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
