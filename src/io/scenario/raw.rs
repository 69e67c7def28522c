//! The scenario file as written: the serde structs of its TOML sections, unknown keys refused,
//! nothing checked yet (`checked` turns them into a [`super::Scenario`]).

use crate::model::symmetry::Group;
use crate::physics::dynamics::Method;
use crate::physics::torque::Interaction;
use crate::planning::commutation::StepModel;
use serde::Deserialize;

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawScenario {
    pub(super) name: Option<String>,
    pub(super) description: Option<String>,
    pub(super) rotor: Option<RawPacking>,
    pub(super) stator: Option<RawPacking>,
    pub(super) magnets: Option<RawMagnets>,
    pub(super) body: Option<RawBody>,
    pub(super) settle: Option<RawSettle>,
    pub(super) plan: Option<RawPlan>,
    pub(super) sweep: Option<RawSweep>,
    pub(super) relay: Option<crate::relay::RelayConfig>,
    pub(super) report: Option<RawReport>,
    pub(super) sensor: Option<crate::io::sensor_section::RawSensor>,
    pub(super) design: Option<RawDesign>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawReport {
    pub(super) reference_deg: Option<f64>,
    pub(super) reference_label: Option<String>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSweep {
    pub(super) axes: Option<AxesSpec>,
    pub(super) axis_count: Option<usize>,
    pub(super) angles_deg: Option<Vec<f64>>,
    pub(super) schemes: Option<Vec<String>>,
    pub(super) models: Option<Vec<String>>,
    pub(super) keep_plans: Option<bool>,
    pub(super) motions: Option<usize>,
    pub(super) seed: Option<u64>,
    pub(super) angle_min_deg: Option<f64>,
    pub(super) angle_max_deg: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(untagged)]
pub(super) enum AxesSpec {
    Named(String),
    List(Vec<[f64; 3]>),
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPlan {
    pub(super) axis: Option<[f64; 3]>,
    pub(super) angle_deg: Option<f64>,
    pub(super) scheme: Option<String>,
    pub(super) model: Option<StepModel>,
    pub(super) pairs_per_step: Option<usize>,
    pub(super) max_pairs_per_step: Option<usize>,
    pub(super) settle_budget: Option<usize>,
    pub(super) settles_per_state: Option<usize>,
    pub(super) stall_settles: Option<usize>,
    pub(super) start: Option<[f64; 4]>,
    pub(super) max_steps: Option<usize>,
    pub(super) beam_width: Option<usize>,
    pub(super) max_step_axis_error_deg: Option<f64>,
    pub(super) min_step_angle_deg: Option<f64>,
    pub(super) error_bound_start_deg: Option<f64>,
    pub(super) search_bound_deg: Option<f64>,
    pub(super) capture_deg: Option<f64>,
    pub(super) max_coils_on: Option<usize>,
    pub(super) max_candidates: Option<usize>,
    pub(super) angle_tolerance_deg: Option<f64>,
    pub(super) tolerance_deg: Option<f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPacking {
    pub(super) preset: Option<String>,
    pub(super) points: Option<Vec<[f64; 3]>>,
    pub(super) file: Option<String>,
    pub(super) group: Option<Group>,
    pub(super) generators: Option<Vec<[f64; 3]>>,
    pub(super) cap_axis: Option<[f64; 3]>,
    pub(super) cap_deg: Option<f64>,
}

#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub(super) enum Shape {
    Gaussian,
    Cosine,
    Table,
    Dipole,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawMagnets {
    pub(super) shape: Option<Shape>,
    pub(super) strength_j: Option<f64>,
    pub(super) width_deg: Option<f64>,
    pub(super) max_attraction_deg: Option<f64>,
    pub(super) table: Option<String>,
    pub(super) interaction: Option<Interaction>,
    // shape = "dipole": the physical parts (SI units)
    pub(super) ball_radius_m: Option<f64>,
    pub(super) magnet_moment_am2: Option<f64>,
    pub(super) remanence_t: Option<f64>,
    pub(super) magnet_volume_m3: Option<f64>,
    pub(super) magnet_diameter_m: Option<f64>,
    pub(super) magnet_thickness_m: Option<f64>,
    pub(super) coil_turns: Option<f64>,
    pub(super) coil_current_a: Option<f64>,
    pub(super) coil_ampere_turns: Option<f64>,
    pub(super) coil_radius_m: Option<f64>,
    pub(super) gap_m: Option<f64>,
    pub(super) core_gain: Option<f64>,
    // real parts: the magnet's shape and a block's sides, a coil's winding
    pub(super) magnet_shape: Option<RawMagnetShape>,
    pub(super) magnet_size_m: Option<[f64; 3]>,
    pub(super) coil_inner_radius_m: Option<f64>,
    pub(super) coil_outer_radius_m: Option<f64>,
    pub(super) coil_length_m: Option<f64>,
}

/// `magnet_shape`: a rotor magnet as a point dipole, a disc or a block.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub(super) enum RawMagnetShape {
    Point,
    Cylinder,
    Cuboid,
}

impl RawMagnets {
    /// The dipole keys given, by name (refused unless shape = "dipole").
    pub(super) fn dipole_keys(&self) -> Vec<&'static str> {
        [
            ("ball_radius_m", self.ball_radius_m.is_some()),
            ("magnet_moment_am2", self.magnet_moment_am2.is_some()),
            ("remanence_t", self.remanence_t.is_some()),
            ("magnet_volume_m3", self.magnet_volume_m3.is_some()),
            ("magnet_diameter_m", self.magnet_diameter_m.is_some()),
            ("magnet_thickness_m", self.magnet_thickness_m.is_some()),
            ("coil_turns", self.coil_turns.is_some()),
            ("coil_current_a", self.coil_current_a.is_some()),
            ("coil_ampere_turns", self.coil_ampere_turns.is_some()),
            ("coil_radius_m", self.coil_radius_m.is_some()),
            ("gap_m", self.gap_m.is_some()),
            ("core_gain", self.core_gain.is_some()),
            ("magnet_shape", self.magnet_shape.is_some()),
            ("magnet_size_m", self.magnet_size_m.is_some()),
            ("coil_inner_radius_m", self.coil_inner_radius_m.is_some()),
            ("coil_outer_radius_m", self.coil_outer_radius_m.is_some()),
            ("coil_length_m", self.coil_length_m.is_some()),
        ]
        .into_iter()
        .filter(|(_, given)| *given)
        .map(|(k, _)| k)
        .collect()
    }
}

#[derive(Debug, Deserialize)]
#[serde(untagged)]
pub(super) enum Inertia {
    Scalar(f64),
    Diagonal([f64; 3]),
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawBody {
    pub(super) inertia_kg_m2: Option<Inertia>,
    pub(super) damping_nms: Option<f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSettle {
    pub(super) omega_tol: Option<f64>,
    pub(super) torque_tol: Option<f64>,
    pub(super) t_max_s: Option<f64>,
    pub(super) rtol: Option<f64>,
    pub(super) atol: Option<f64>,
    pub(super) method: Option<Method>,
    pub(super) arrival_deg: Option<f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawDesign {
    pub(super) free: Option<String>,
    pub(super) coils: Option<usize>,
    pub(super) coils_min: Option<usize>,
    pub(super) coils_max: Option<usize>,
    pub(super) magnets: Option<usize>,
    pub(super) magnets_min: Option<usize>,
    pub(super) magnets_max: Option<usize>,
    pub(super) cap_axis: Option<[f64; 3]>,
    pub(super) cap_deg: Option<f64>,
    pub(super) coil_separation_deg: Option<f64>,
    pub(super) magnet_separation_deg: Option<f64>,
    pub(super) families: Option<Vec<String>>,
    pub(super) axes: Option<usize>,
    pub(super) full_axes: Option<usize>,
    pub(super) axis_seed: Option<u64>,
    pub(super) population: Option<usize>,
    pub(super) generations: Option<usize>,
    pub(super) angle_deg: Option<f64>,
    pub(super) rotation_deg: Option<f64>,
    pub(super) move_deg: Option<f64>,
}
