//! Random active sets for the basin checks (tests/it/basins.rs and research/basins.rs share this
//! file): the basin checks' setup, a deterministic generator, and the comparison of a settle with
//! the reference; also the planner-like sets (`planner_sets`, for
//! research/settle_sets.rs and benches/settle.rs).
#![allow(dead_code)]

use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use spherestep::io::scenario::Scenario;
use spherestep::model::geometry::{Orientation, Pair, Radians};
use spherestep::physics::dynamics::{settle, Body, SettleParams, SettleResult};
use spherestep::physics::torque::{MagnetTorques, Well, WellShape};

/// splitmix64: a small deterministic generator (same numbers on every machine).
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in 0..n.
    pub fn below(&mut self, n: usize) -> usize {
        (self.uniform() * n as f64) as usize % n.max(1)
    }

    /// A uniformly random rotation (Shoemake's method).
    pub fn orientation(&mut self) -> Orientation {
        let (u1, u2, u3) = (self.uniform(), self.uniform(), self.uniform());
        let tau = std::f64::consts::TAU;
        let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
        UnitQuaternion::from_quaternion(Quaternion::new(
            b * (tau * u3).cos(),
            a * (tau * u2).sin(),
            a * (tau * u2).cos(),
            b * (tau * u3).sin(),
        ))
    }
}

/// Well shape of a kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    Gaussian,
    Cosine,
}

/// One kind of random set: well shape, damping (fraction of critical for one aligned pair) and
/// the number of pairs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Kind {
    pub shape: Shape,
    pub damping_ratio: f64,
    pub pairs: usize,
}

/// The basin checks' setup: the prototype's 80 magnets and 16 coils; gaussian wells k = 0.144 J,
/// sigma = 10 deg (or cosine wells of the same stiffness at d = 0, k / sigma^2), reach 25 deg;
/// I = 0.023 kg m^2; damping `ratio` of critical for one pair, 2 sqrt(K I); omega_tol 1e-4,
/// torque_tol 1e-6, t_max 30 s.
pub fn setup(shape: Shape, damping_ratio: f64) -> (MagnetTorques, Body, SettleParams) {
    let sc = Scenario::prototype();
    let k = 0.144;
    let sigma = 10f64.to_radians();
    let stiffness = k / (sigma * sigma);
    let shape = match shape {
        Shape::Gaussian => WellShape::Gaussian {
            strength_j: k,
            width: Radians(sigma),
        },
        Shape::Cosine => WellShape::Cosine {
            strength_j: stiffness,
        },
    };
    let torques = MagnetTorques {
        well: Well::new(shape, Radians(25f64.to_radians())),
        ..sc.torques.clone()
    };
    let inertia = 0.023;
    let body = Body {
        inertia: Vector3::repeat(inertia),
        damping: damping_ratio * 2.0 * (stiffness * inertia).sqrt(),
    };
    let params = SettleParams {
        omega_tol: 1e-4,
        torque_tol: 1e-6,
        t_max: 30.0,
        ..sc.settle
    };
    (torques, body, params)
}

/// `n` random sets of `pairs` pairs at `q0`: distinct coils, each with a magnet drawn among
/// those within the well's reach of it (distinct magnets).
pub fn random_sets(
    torques: &MagnetTorques,
    q0: &Orientation,
    pairs: usize,
    n: usize,
    rng: &mut Rng,
) -> Vec<Vec<Pair>> {
    let r = q0.to_rotation_matrix();
    let reach = torques.well.max_attraction().0.cos();
    let in_reach: Vec<Vec<usize>> = torques
        .stator
        .iter()
        .map(|s| {
            (0..torques.rotor.len())
                .filter(|&j| (r * torques.rotor[j]).dot(s) > reach)
                .collect()
        })
        .collect();
    let usable: Vec<usize> = (0..in_reach.len())
        .filter(|&c| !in_reach[c].is_empty())
        .collect();
    assert!(usable.len() >= pairs, "too few coils reach a magnet");
    let mut sets = Vec::with_capacity(n);
    while sets.len() < n {
        let mut set: Vec<Pair> = Vec::with_capacity(pairs);
        let mut tries = 0;
        while set.len() < pairs && tries < 100 {
            tries += 1;
            let c = usable[rng.below(usable.len())];
            let m = in_reach[c][rng.below(in_reach[c].len())];
            if set.iter().any(|p| p.coil.0 == c || p.magnet.0 == m) {
                continue;
            }
            set.push(Pair::new(c, m));
        }
        if set.len() == pairs {
            sets.push(set);
        }
    }
    sets
}

/// `n` sets as a planner meets them, each from its own random start: three
/// distinct coils, each with a distinct magnet within `reach_deg` of it at that start (a start
/// where fewer than three coils reach a magnet is drawn again).
pub fn planner_sets(
    torques: &MagnetTorques,
    n: usize,
    reach_deg: f64,
    rng: &mut Rng,
) -> Vec<(Orientation, Vec<Pair>)> {
    let reach = reach_deg.to_radians().cos();
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let q0 = rng.orientation();
        let r = q0.to_rotation_matrix();
        let in_reach: Vec<(usize, Vec<usize>)> = torques
            .stator
            .iter()
            .enumerate()
            .map(|(c, s)| {
                let near = (0..torques.rotor.len())
                    .filter(|&j| (r * torques.rotor[j]).dot(s) > reach)
                    .collect();
                (c, near)
            })
            .filter(|(_, near): &(usize, Vec<usize>)| !near.is_empty())
            .collect();
        if in_reach.len() < 3 {
            continue;
        }
        let mut set: Vec<Pair> = Vec::with_capacity(3);
        let mut tries = 0;
        while set.len() < 3 && tries < 100 {
            tries += 1;
            let (c, near) = &in_reach[rng.below(in_reach.len())];
            let m = near[rng.below(near.len())];
            if !set.iter().any(|p| p.coil.0 == *c || p.magnet.0 == m) {
                set.push(Pair::new(*c, m));
            }
        }
        if set.len() == 3 {
            out.push((q0, set));
        }
    }
    out
}

/// How a settle compares with the reference's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Comparison {
    /// Angle between the two final orientations, rad.
    pub angle: f64,
    /// |t_fast - t_ref|.
    pub dt: f64,
    /// Whether the two agree on the settled flag.
    pub same_flag: bool,
    /// Both settled, more than 1e-3 rad apart: another equilibrium.
    pub other_basin: bool,
    /// Within the agreement bounds: 1e-4 rad, 2% + 0.05 s, same flag.
    pub agrees: bool,
}

pub fn compare(fast: &SettleResult, reference: &SettleResult) -> Comparison {
    let angle = fast.q.angle_to(&reference.q);
    let dt = (fast.settle_time_s - reference.settle_time_s).abs();
    let same_flag = fast.settled == reference.settled;
    let both = fast.settled && reference.settled;
    let other_basin = both && angle > 1e-3;
    let agrees =
        same_flag && (!both || (angle < 1e-4 && dt <= 0.02 * reference.settle_time_s + 0.05));
    Comparison {
        angle,
        dt,
        same_flag,
        other_basin,
        agrees,
    }
}

/// Settles `set` with `params` and with the reference.
pub fn both(
    torques: &MagnetTorques,
    set: &[Pair],
    q0: &Orientation,
    body: Body,
    params: SettleParams,
) -> (SettleResult, SettleResult) {
    (
        settle(torques, set, q0, body, params),
        settle(torques, set, q0, body, params.reference()),
    )
}
