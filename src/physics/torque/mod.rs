//! Magnet torques: the pair potential wells (gaussian, cosine, measured table) with their
//! cut-off at the maximum attraction distance, the "pairs" and "coils" interactions, and the
//! [`TorqueModel`] trait through which the dynamics sees them (so that another physical model,
//! e.g. dipoles, can be added without touching the integrator).

use crate::model::geometry::{Pair, Radians};
use crate::physics::magnetics::DipoleWell;
use crate::physics::profile::Profile;
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

mod nearby;

pub use nearby::NearbyMagnets;

/// What the dynamics needs from a torque model.
pub trait TorqueModel: Sync {
    /// World-frame torque on the rotor (N m) and potential energy (J) at orientation `r`
    /// (body-to-world rotation matrix) with the active set `active`.
    fn torque_energy(&self, r: &Matrix3<f64>, active: &[Pair]) -> (Vector3<f64>, f64);

    /// World-frame torque only (the hot path of the integrator).
    fn torque(&self, r: &Matrix3<f64>, active: &[Pair]) -> Vector3<f64> {
        self.torque_energy(r, active).0
    }

    /// Body-frame torque N_B = R^T N (what the equations of motion use).
    fn body_torque(&self, r: &Matrix3<f64>, active: &[Pair]) -> Vector3<f64> {
        r.transpose() * self.torque(r, active)
    }

    /// Body-frame torque at the orientation of an unnormalised quaternion `q` = (x, y, z, w),
    /// the integrator's state: by default [`TorqueModel::body_torque`] of its
    /// [`rotation_matrix`]; a model that turns only a few world vectors into the body frame may
    /// use [`QuaternionRotation::to_body`] instead.
    fn body_torque_at(&self, q: &[f64; 4], active: &[Pair]) -> Vector3<f64> {
        self.body_torque(&rotation_matrix(q[0], q[1], q[2], q[3]), active)
    }

    /// The body-frame torque and its derivative with respect to a small body-frame rotation
    /// (`R -> R exp([delta]x)`), for the settle's linear end phase; `None` when the model has no
    /// analytic derivative (the settle then integrates to the end).
    fn linearize(&self, _r: &Matrix3<f64>, _active: &[Pair]) -> Option<Linearization> {
        None
    }

    /// A typical stiffness of one aligned pair (N m / rad): the scale at which the settle looks
    /// for the linear regime. `None` when the model offers no [`TorqueModel::linearize`].
    fn stiffness_scale(&self) -> Option<f64> {
        None
    }

    /// The same model for the motion from `r0` with `active` on, restricted to the magnets that
    /// can come within reach of an energised coil while the ball stays within [`NEAR_SKIN`] of
    /// `r0` (beyond it, lists built again where the ball went): the same torques to the bit,
    /// at a fraction of the cost where every coil pulls every magnet. `None` where there is
    /// nothing to gain.
    fn nearby<'s>(&'s self, _r0: &Matrix3<f64>, _active: &'s [Pair]) -> Option<NearbyMagnets<'s>> {
        None
    }

    /// Each pulling pair's cut-off margin m = p . s - cos(d_max) (positive within reach) and its
    /// rate dm/dt at orientation `r` (body to world) and body rate `w`, appended to `out`, for
    /// the settle's graze test: the active pairs ("pairs" interaction), or every energised
    /// coil with each magnet that may come within its reach ([`NearbyMagnets`], "coils"), always
    /// in the same order; `false` where the model offers none (a well whose torque does not
    /// jump at its cut-off, the whole "coils" model, a [`NearbyMagnets`] beyond its skin).
    fn cutoff_margins(
        &self,
        _r: &Matrix3<f64>,
        _w: &Vector3<f64>,
        _active: &[Pair],
        _out: &mut Vec<(f64, f64)>,
    ) -> bool {
        false
    }

    /// [`TorqueModel::cutoff_margins`] of the pairs whose bit is set in `pairs` only (the same
    /// bits), each written at its index in `out`, which holds a place for every pair; the others
    /// are left as they are. `false` where [`TorqueModel::cutoff_margins`] offers none (with
    /// `pairs` empty, only that is asked). By default every margin is computed and the asked
    /// ones are copied.
    fn cutoff_margins_of(
        &self,
        r: &Matrix3<f64>,
        w: &Vector3<f64>,
        active: &[Pair],
        pairs: SideMask,
        out: &mut [(f64, f64)],
    ) -> bool {
        let mut all = Vec::with_capacity(out.len());
        if !self.cutoff_margins(r, w, active, &mut all) {
            return false;
        }
        for (i, (o, m)) in out.iter_mut().zip(all).enumerate() {
            if i < SideMask::BITS as usize && pairs >> i & 1 == 1 {
                *o = m;
            }
        }
        true
    }

    /// Whether the settle may treat the cut-offs of `active` as events
    /// ([`TorqueModel::body_torque_within`]): a well whose torque jumps at its cut-off, at most
    /// [`MAX_EVENT_PAIRS`] pairs, in the "pairs" interaction (the active pairs) or a [`NearbyMagnets`] of the
    /// "coils" interaction (each energised coil with each magnet that may come within its
    /// reach). `false` by default.
    fn cutoff_events(&self, _active: &[Pair]) -> bool {
        false
    }

    /// Where a settle with cut-off events goes on beyond the skin of a [`NearbyMagnets`] (which
    /// offers no margins there) from the orientation `r` within it: the model on lists built at
    /// `r`, and the sides `within` of this model's pairs (a bit for each held within reach)
    /// carried over to that one's by (coil, magnet). `None` by default, and where the settle
    /// cannot go on so (see `NearbyMagnets`'s).
    fn continued_at(
        &self,
        _r: &Matrix3<f64>,
        _active: &[Pair],
        _within: SideMask,
    ) -> Option<(Self, SideMask)>
    where
        Self: Sized,
    {
        None
    }

    /// Body-frame torque at the orientation of an unnormalised quaternion `q` with only the
    /// pairs of `active` whose bit is set in `within` pulling, each by its well's formula
    /// continued beyond the cut-off: the smooth torque of one side of each cut-off, which the
    /// settle integrates between the cut-off events (where a margin of
    /// [`TorqueModel::cutoff_margins`] changes sign and the bit is flipped). Within reach it
    /// is [`TorqueModel::body_torque_at`]'s to the bit. By default that torque itself.
    fn body_torque_within(&self, q: &[f64; 4], active: &[Pair], _within: SideMask) -> Vector3<f64> {
        self.body_torque_at(q, active)
    }

    /// Whether the settle may trust a minimum near a well's cut-off that the ball came to
    /// without any margin of [`TorqueModel::cutoff_margins`] changing sign on the way (see
    /// `dynamics::end_phase::CUTOFF_SAFETY`): measured so for the "pairs" interaction, not for "coils".
    fn trusts_uncrossed_cutoffs(&self) -> bool {
        false
    }
}

/// The torque near an orientation, to first order: N_B(delta) = torque + jacobian delta.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Linearization {
    /// Body-frame torque N_B, N m.
    pub torque: Vector3<f64>,
    /// dN_B / d delta, N m / rad (minus the stiffness; symmetric at an equilibrium).
    pub jacobian: Matrix3<f64>,
    /// The smallest distance of any magnet's angle from the well's cut-off, rad, capped at
    /// [`MARGIN_CAP`]: the torque is smooth (and the linearization good) only within it, and
    /// only a small margin matters.
    pub cutoff_margin: f64,
}

/// The cap of [`Linearization::cutoff_margin`], rad: magnets farther than this beyond the
/// cut-off are passed over without trigonometry.
pub const MARGIN_CAP: f64 = 0.1;

/// How far (rad, 20 degrees) the ball may turn from where a [`NearbyMagnets`] was built before
/// its lists are built again (and its cut-off margins go off): the settles a planner weighs
/// turn the ball by a few degrees.
pub const NEAR_SKIN: f64 = 0.35;

/// The sides of the pairs' cut-offs between the settle's cut-off events, a bit per pair (set:
/// held within reach): [`TorqueModel::body_torque_within`].
pub type SideMask = u128;

/// At most this many pairs' cut-offs are events (the bits of a [`SideMask`]): a "coils" set of
/// three or four coils in wells reaching 40 degrees lists 70 to 100 (coil, magnet) pairs.
pub const MAX_EVENT_PAIRS: usize = 128;

/// A mask of the first `n` bits (all of them from [`SideMask::BITS`] on).
pub(crate) fn first_bits(n: usize) -> SideMask {
    match n {
        0 => 0,
        n if n >= SideMask::BITS as usize => SideMask::MAX,
        n => SideMask::MAX >> (SideMask::BITS as usize - n),
    }
}

/// The set bits of `mask`, in ascending order.
pub(crate) fn set_bits(mut mask: SideMask) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let i = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            i
        })
    })
}

/// The mask with the bits `indices` set (each below [`SideMask::BITS`]): [`set_bits`]'s inverse.
pub(crate) fn bits_of(indices: impl Iterator<Item = usize>) -> SideMask {
    indices.fold(0, |acc: SideMask, i| acc | 1 << i)
}

/// The pairs held within reach by their cut-off `margins` (m, dm/dt): a bit for each margin
/// not below zero (at most [`SideMask::BITS`] margins).
pub(crate) fn within_reach(margins: &[(f64, f64)]) -> SideMask {
    bits_of((margins.iter().enumerate()).filter_map(|(i, &(m, _))| (m >= 0.0).then_some(i)))
}

/// The body-to-world rotation matrix of the quaternion (x, y, z, w), which need not be
/// normalised: it is the rotation of q / |q|, built without a square root or trigonometry.
#[inline]
pub fn rotation_matrix(x: f64, y: f64, z: f64, w: f64) -> Matrix3<f64> {
    let s = 2.0 / (x * x + y * y + z * z + w * w);
    let (xs, ys, zs) = (x * s, y * s, z * s);
    let (wx, wy, wz) = (w * xs, w * ys, w * zs);
    let (xx, xy, xz) = (x * xs, x * ys, x * zs);
    let (yy, yz, zz) = (y * ys, y * zs, z * zs);
    Matrix3::new(
        1.0 - (yy + zz),
        xy - wz,
        xz + wy,
        xy + wz,
        1.0 - (xx + zz),
        yz - wx,
        xz - wy,
        yz + wx,
        1.0 - (xx + yy),
    )
}

/// The rotation of an unnormalised quaternion (x, y, z, w), for turning a few world vectors
/// into the body frame: R^T v = M^T v / |q|^2 with M = |q|^2 R, whose entries are products of
/// q's components. The division then runs beside the products instead of before them (an
/// evaluation of the torque is one chain of dependent operations).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QuaternionRotation {
    m: Matrix3<f64>,
    inv_norm2: f64,
}

impl QuaternionRotation {
    /// The rotation of `[x, y, z, w]` (any non-zero norm).
    #[inline]
    pub fn new(&[x, y, z, w]: &[f64; 4]) -> Self {
        let (xx, yy, zz, ww) = (x * x, y * y, z * z, w * w);
        let (xy, xz, yz) = (x * y, x * z, y * z);
        let (wx, wy, wz) = (w * x, w * y, w * z);
        let m = Matrix3::new(
            (ww + xx) - (yy + zz),
            2.0 * (xy - wz),
            2.0 * (xz + wy),
            2.0 * (xy + wz),
            (ww + yy) - (xx + zz),
            2.0 * (yz - wx),
            2.0 * (xz - wy),
            2.0 * (yz + wx),
            (ww + zz) - (xx + yy),
        );
        QuaternionRotation {
            m,
            inv_norm2: 1.0 / ((xx + yy) + (zz + ww)),
        }
    }

    /// R^T v: a world-frame vector in the body frame.
    #[inline]
    pub fn to_body(&self, v: &Vector3<f64>) -> Vector3<f64> {
        self.m.tr_mul(v) * self.inv_norm2
    }
}

/// Shape of a pair's potential well U(d).
#[derive(Debug, Clone, PartialEq)]
pub enum WellShape {
    /// U = -k exp(-d^2 / (2 sigma^2)): a sharp well (custom-wound coils).
    Gaussian {
        /// The well's depth k (U = -k at d = 0), J.
        strength_j: f64,
        /// Its width sigma, radians.
        width: Radians,
    },
    /// U = -k cos d: a broad well (off-the-shelf coils).
    Cosine {
        /// The well's depth k (U = -k at d = 0), J.
        strength_j: f64,
    },
    /// g(d) = U'(d) read from a measured or computed curve, linearly interpolated.
    Table(TorqueTable),
    /// Physical magnets: a radial point dipole passing a coil's current loop, g(d) from the
    /// 3-D torque x x F + m x B (`magnetics`); it attracts out to where g crosses zero, and
    /// repels weakly beyond.
    Dipole(DipoleWell),
}

/// A torque curve g(d): angles (radians, ascending, starting at 0) and torques (N m; positive
/// pulls the magnet towards the coil, negative pushes it away, as a physical coil's field does
/// beyond its winding).
#[derive(Debug, Clone, PartialEq)]
pub struct TorqueTable {
    d: Vec<f64>,
    g: Vec<f64>,
    /// integral of g from 0 to d[i]
    cum: Vec<f64>,
}

impl TorqueTable {
    /// Builds a table from (degrees, N m) rows; the error says which row is wrong and why.
    pub fn from_rows(rows: &[(f64, f64)]) -> Result<Self, String> {
        if rows.len() < 2 {
            return Err("expected at least two rows (angle_deg, torque_nm)".into());
        }
        if rows[0].0 != 0.0 {
            return Err(format!(
                "row 1: expected the first angle to be 0 degrees, got {}",
                crate::text::shown(rows[0].0)
            ));
        }
        for (i, &(d, g)) in rows.iter().enumerate() {
            if !d.is_finite() || !g.is_finite() {
                return Err(format!("row {}: expected finite numbers", i + 1));
            }
            if i > 0 && d <= rows[i - 1].0 {
                return Err(format!(
                    "row {}: expected angles strictly increasing, got {} after {}",
                    i + 1,
                    crate::text::shown(d),
                    crate::text::shown(rows[i - 1].0)
                ));
            }
            if d > 180.0 {
                return Err(format!("row {}: expected an angle <= 180 degrees", i + 1));
            }
        }
        let d: Vec<f64> = rows.iter().map(|r| r.0.to_radians()).collect();
        let g: Vec<f64> = rows.iter().map(|r| r.1).collect();
        let mut cum = vec![0.0; d.len()];
        for i in 1..d.len() {
            cum[i] = cum[i - 1] + 0.5 * (g[i] + g[i - 1]) * (d[i] - d[i - 1]);
        }
        Ok(TorqueTable { d, g, cum })
    }

    fn segment(&self, d: f64) -> Option<usize> {
        if d > *self.d.last()? {
            return None;
        }
        // last index i with self.d[i] <= d, capped so that i + 1 exists
        let i = self.d.partition_point(|&x| x <= d).saturating_sub(1);
        Some(i.min(self.d.len() - 2))
    }

    /// g(d), 0 beyond the table.
    pub fn g(&self, d: f64) -> f64 {
        match self.segment(d) {
            None => 0.0,
            Some(i) => {
                let t = (d - self.d[i]) / (self.d[i + 1] - self.d[i]);
                self.g[i] + t * (self.g[i + 1] - self.g[i])
            }
        }
    }

    /// Integral of g from 0 to d (constant beyond the table).
    fn integral(&self, d: f64) -> f64 {
        match self.segment(d) {
            None => *self.cum.last().unwrap_or(&0.0),
            Some(i) => {
                let x = d - self.d[i];
                let slope = (self.g[i + 1] - self.g[i]) / (self.d[i + 1] - self.d[i]);
                self.cum[i] + self.g[i] * x + 0.5 * slope * x * x
            }
        }
    }

    /// Slope of g at 0 (used for g(d)/sin d as d -> 0).
    fn slope0(&self) -> f64 {
        (self.g[1] - self.g[0]) / (self.d[1] - self.d[0])
    }
}

/// How coils attract magnets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Interaction {
    /// Only the paired magnet of an active pair is attracted (the paper's model).
    #[default]
    Pairs,
    /// An energised coil attracts every rotor magnet within the maximum attraction distance.
    Coils,
}

/// A pair potential: its shape and the maximum distance of attraction (g = 0 beyond it), with
/// the fitted profile its torques are evaluated through where its shape has one.
#[derive(Debug, Clone)]
pub struct Well {
    shape: WellShape,
    max_attraction: Radians,
    profile: Option<Profile>,
    /// The cosines of the cut-off, of the cut-off less [`MARGIN_CAP`] (2: none) and of the
    /// cut-off plus it (-2 where an angle passes the antipode): the evaluations' early tests.
    cos_cutoff: f64,
    cos_near: f64,
    cos_far: f64,
    /// Whether the torque jumps at the cut-off (see [`Well::jumps_at_cutoff`]).
    cutoff_jump: bool,
}

/// A cut-off where g is below this fraction of its peak within the cut-off is continuous (a
/// dipole's ends where its pull does: 1e-14 of the peak).
const JUMP_FLOOR: f64 = 1e-6;

/// Two wells are the same physics when their shapes and cut-offs are (the profile follows).
impl PartialEq for Well {
    fn eq(&self, other: &Well) -> bool {
        self.shape == other.shape && self.max_attraction == other.max_attraction
    }
}

impl Well {
    /// The well of `shape` cut off at `max_attraction`, its profile fitted (a fraction of a
    /// millisecond for the smooth shapes).
    pub fn new(shape: WellShape, max_attraction: Radians) -> Well {
        let mut well = Well {
            shape,
            max_attraction,
            profile: None,
            cos_cutoff: cos_within(max_attraction.0),
            cos_near: if max_attraction.0 > MARGIN_CAP {
                (max_attraction.0 - MARGIN_CAP).cos()
            } else {
                2.0
            },
            cos_far: cos_within(max_attraction.0 + MARGIN_CAP),
            cutoff_jump: false,
        };
        let d_max = max_attraction.0.min(std::f64::consts::PI);
        let peak = (0..=64)
            .map(|i| well.g_uncut(d_max * i as f64 / 64.0).abs())
            .fold(0.0, f64::max);
        well.cutoff_jump = well.g_uncut(d_max).abs() > JUMP_FLOOR * peak;
        // 1 - cos(d_max), and the whole sphere (u = 2) where the cut-off passes the antipode
        let u_max = (1.0 - well.cos_cutoff).min(2.0);
        well.profile = Profile::fit(
            |u: f64| {
                let d = 2.0 * (0.5 * u).sqrt().min(1.0).asin();
                well.f_within(d, (u * (2.0 - u)).max(0.0).sqrt())
            },
            u_max,
        );
        well
    }

    /// The shape of the potential.
    pub fn shape(&self) -> &WellShape {
        &self.shape
    }

    /// The maximum distance of attraction (g = 0 beyond it).
    pub fn max_attraction(&self) -> Radians {
        self.max_attraction
    }

    /// Whether the torques are evaluated through a fitted profile (else by the formula).
    pub fn has_profile(&self) -> bool {
        self.profile.is_some()
    }

    /// Whether the torque jumps at the cut-off (g there above a millionth of its peak): only
    /// then can a magnet grazing it send the ball elsewhere than a small error would (the
    /// settle's graze test).
    pub fn jumps_at_cutoff(&self) -> bool {
        self.cutoff_jump
    }

    /// The cut-off margin m = p . s - cos(d_max) of a magnet `p` and a coil `s` (both in the
    /// body frame; positive within reach) and its rate dm/dt = (w x p) . s at body rate `w`.
    fn cutoff_margin(&self, p: &Vector3<f64>, s: &Vector3<f64>, w: &Vector3<f64>) -> (f64, f64) {
        (p.dot(s) - self.cos_cutoff, w.cross(p).dot(s))
    }

    /// Potential U(d) in J, continuous, constant beyond the cut-off.
    pub fn potential(&self, d: f64) -> f64 {
        let d = d.min(self.max_attraction.0);
        match &self.shape {
            WellShape::Gaussian { strength_j, width } => {
                -strength_j * (-d * d / (2.0 * width.0 * width.0)).exp()
            }
            WellShape::Cosine { strength_j } => -strength_j * d.cos(),
            WellShape::Table(t) => t.integral(d) - t.integral(self.max_attraction.0),
            WellShape::Dipole(w) => w.potential(d),
        }
    }

    /// Torque magnitude g(d) = dU/dd >= 0 (the pull -dU/dd points back towards the coil), in
    /// N m (0 beyond the cut-off).
    pub fn g(&self, d: f64) -> f64 {
        if d > self.max_attraction.0 {
            return 0.0;
        }
        self.g_uncut(d)
    }

    /// g(d) by the shape's formula, whatever the cut-off.
    fn g_uncut(&self, d: f64) -> f64 {
        match &self.shape {
            WellShape::Gaussian { strength_j, width } => {
                let s2 = width.0 * width.0;
                strength_j * d / s2 * (-d * d / (2.0 * s2)).exp()
            }
            WellShape::Cosine { strength_j } => strength_j * d.sin(),
            WellShape::Table(t) => t.g(d),
            WellShape::Dipole(w) => w.g(d),
        }
    }

    /// g(d) / sin d, with its limit at d -> 0 (no NaN when aligned); 0 beyond the cut-off and
    /// at the antipode, where the direction of the pull is undefined.
    #[inline]
    pub fn g_over_sin(&self, d: f64, sin_d: f64) -> f64 {
        if d > self.max_attraction.0 {
            return 0.0;
        }
        self.f_within(d, sin_d)
    }

    /// g(d) / sin d by the shape's formula, whatever the cut-off (see [`Well::g_over_sin`]).
    #[inline]
    fn f_within(&self, d: f64, sin_d: f64) -> f64 {
        const SMALL: f64 = 1e-7;
        match &self.shape {
            WellShape::Gaussian { strength_j, width } => {
                let inv_s2 = 1.0 / (width.0 * width.0);
                let d_over_sin = if sin_d < SMALL {
                    if d > 1.0 {
                        return 0.0;
                    }
                    1.0 + d * d / 6.0
                } else {
                    d / sin_d
                };
                strength_j * inv_s2 * d_over_sin * (-0.5 * d * d * inv_s2).exp()
            }
            WellShape::Cosine { strength_j } => {
                if sin_d < SMALL && d > 1.0 {
                    0.0
                } else {
                    *strength_j
                }
            }
            WellShape::Table(_) | WellShape::Dipole(_) => {
                if sin_d < SMALL {
                    if d > 1.0 {
                        0.0
                    } else {
                        self.stiffness()
                    }
                } else {
                    self.g_uncut(d) / sin_d
                }
            }
        }
    }

    /// f(d) = g(d) / sin d and f'(d) / sin d, for the torque's derivative; `None` for a table
    /// (no analytic derivative) and at the antipode. Both 0 beyond the cut-off.
    #[inline]
    fn f_and_slope(&self, d: f64, sin_d: f64) -> Option<(f64, f64)> {
        if d > self.max_attraction.0 {
            return Some((0.0, 0.0));
        }
        if sin_d < 1e-7 && d > 1.0 {
            return None;
        }
        match &self.shape {
            WellShape::Gaussian { strength_j, width } => {
                let inv_s2 = 1.0 / (width.0 * width.0);
                let e = strength_j * inv_s2 * (-0.5 * d * d * inv_s2).exp();
                // (d / sin d) and (sin d - d cos d) / sin^3 d, by series near 0
                let (d_over_sin, bracket) = if d < 1e-3 {
                    (1.0 + d * d / 6.0, 1.0 / 3.0 + 2.0 * d * d / 15.0)
                } else {
                    let s3 = sin_d * sin_d * sin_d;
                    (d / sin_d, (sin_d - d * d.cos()) / s3)
                };
                let f = e * d_over_sin;
                let slope = e * (bracket - d_over_sin * d_over_sin * inv_s2);
                Some((f, slope))
            }
            WellShape::Cosine { strength_j } => Some((*strength_j, 0.0)),
            WellShape::Table(_) => None,
            WellShape::Dipole(w) => Some(dipole_f_and_slope(w, d, sin_d)),
        }
    }

    /// Torque of one coil at `s` on one magnet at `p` (both in the same frame; the torque is
    /// in that frame). A magnet whose cosine is below `cos_cutoff` (the cosine of the maximum
    /// attraction distance, or -2 for no early test) is rejected before any trigonometry.
    /// Always inlined: where the compiler's partition left it a call, settle/pairs/4 took 30
    /// instead of 21 us (before the profiles).
    #[inline(always)]
    pub(crate) fn pair_torque(
        &self,
        p: &Vector3<f64>,
        s: &Vector3<f64>,
        cos_cutoff: f64,
    ) -> Vector3<f64> {
        let c = p.dot(s);
        if c < cos_cutoff {
            return Vector3::zeros();
        }
        let x = p.cross(s);
        match &self.profile {
            Some(profile) => x * profile.value(1.0 - c),
            None => x * self.formula_f(&x, c),
        }
    }

    /// [`Well::pair_torque`] (no early test; the same arithmetic) within reach, and beyond the
    /// cut-off the shape's formula continued: the smooth torque of a pair the settle holds
    /// within reach between its cut-off events ([`TorqueModel::body_torque_within`]).
    #[inline(always)]
    pub(crate) fn pair_torque_continued(&self, p: &Vector3<f64>, s: &Vector3<f64>) -> Vector3<f64> {
        let c = p.dot(s);
        if c < self.cos_cutoff {
            return self.continued(p, s, c);
        }
        let x = p.cross(s);
        match &self.profile {
            Some(profile) => x * profile.value(1.0 - c),
            None => x * self.formula_f(&x, c),
        }
    }

    /// The pair torque beyond the cut-off by the formula without its cut (out of line: rare).
    #[inline(never)]
    fn continued(&self, p: &Vector3<f64>, s: &Vector3<f64>, c: f64) -> Vector3<f64> {
        let x = p.cross(s);
        let sin_d = x.norm();
        x * self.f_within(angle_from_sin_cos(sin_d, c), sin_d)
    }

    /// g(d) / sin d by the shape's formula, for a magnet and coil whose cross product is `x` and
    /// dot product `c`: the wells without a profile. Kept out of line, so that the profiled
    /// evaluation's loop stays small.
    #[inline(never)]
    fn formula_f(&self, x: &Vector3<f64>, c: f64) -> f64 {
        let sin_d = x.norm();
        self.g_over_sin(angle_from_sin_cos(sin_d, c), sin_d)
    }

    /// The torque (N m) one energised coil exerts on one magnet `d` radians from it, about the
    /// axis that turns the magnet towards the coil (positive: a pull), through the pair torque
    /// the model sums in every evaluation: what a bench measures as a magnet passes a coil,
    /// and what a `table` well reads back. 0 at d = 0, where the pull has no direction.
    pub fn passing_torque(&self, d: f64) -> f64 {
        let s = Vector3::new(0.0, 0.0, -1.0);
        // the magnet d from the coil in the x-z plane; the pull turns it about p x s (+y)
        let p = Vector3::new(d.sin(), 0.0, -d.cos());
        let pull = p.cross(&s);
        let n = pull.norm();
        if n == 0.0 {
            return 0.0;
        }
        self.pair_torque(&p, &s, -2.0).dot(&(pull / n))
    }

    /// The largest |g(d)| within the cut-off (N m): the strongest torque one coil exerts on
    /// one magnet, the scale of every torque of the well (a table's largest entry in reach, a
    /// push included).
    pub fn peak_torque(&self) -> f64 {
        let d_max = self.max_attraction.0.min(std::f64::consts::PI);
        let at = |d: f64| self.g_uncut(d.min(d_max)).abs();
        match &self.shape {
            WellShape::Gaussian { width, .. } => at(width.0),
            WellShape::Cosine { .. } => at(std::f64::consts::FRAC_PI_2),
            WellShape::Table(t) => {
                t.d.iter()
                    .filter(|&&d| d <= d_max)
                    .map(|&d| at(d))
                    .fold(at(d_max), f64::max)
            }
            WellShape::Dipole(w) => {
                let (d, g) = w.peak();
                if d <= d_max {
                    g.abs().max(at(d_max))
                } else {
                    at(d_max)
                }
            }
        }
    }

    /// Stiffness dg/dd at d = 0 (N m / rad): how hard a single aligned pair holds.
    pub fn stiffness(&self) -> f64 {
        match &self.shape {
            WellShape::Gaussian { strength_j, width } => strength_j / (width.0 * width.0),
            WellShape::Cosine { strength_j } => *strength_j,
            WellShape::Table(t) => t.slope0(),
            WellShape::Dipole(w) => w.stiffness(),
        }
    }
}

/// f(d) = g(d) / sin d of a dipole well and f'(d) / sin d, the slope by central differences of
/// the exact f (h = 1e-5 rad: a relative error near 1e-9, which only the linear end phase's
/// Newton steps and modes see, never the torque). f is even in d, so near 0 f'(d) / sin d is
/// its curvature there.
fn dipole_f_and_slope(w: &DipoleWell, d: f64, sin_d: f64) -> (f64, f64) {
    const H: f64 = 1e-5;
    const NEAR_ZERO: f64 = 1e-3;
    let f = |x: f64| w.g(x) / x.sin();
    if d < NEAR_ZERO {
        let k = w.stiffness();
        let f0 = if sin_d < 1e-7 { k } else { f(d) };
        return (f0, 2.0 * (f(NEAR_ZERO) - k) / (NEAR_ZERO * NEAR_ZERO));
    }
    (f(d), (f(d + H) - f(d - H)) / (2.0 * H) / sin_d)
}

/// Adds one pair's terms to `lin`: N += f u and dN/d delta += (s p^T - c 1) f - u u^T slope,
/// element by element with nalgebra's operations in its order (s p^T and u u^T are the
/// products s_i p_j and u_i u_j, c 1 is 1 c on the diagonal and 0 c off it, then the scalings,
/// the difference and the sum), so the same bits, signed zeros included, without the
/// temporary matrices.
#[inline(always)]
fn add_pair_terms(
    lin: &mut Linearization,
    p: &Vector3<f64>,
    s: &Vector3<f64>,
    u: &Vector3<f64>,
    c: f64,
    f: f64,
    slope: f64,
) {
    lin.torque += u * f;
    let off = 0.0 * c;
    for j in 0..3 {
        for i in 0..3 {
            let ic = if i == j { c } else { off };
            let term = (s[i] * p[j] - ic) * f - u[i] * u[j] * slope;
            lin.jacobian[(i, j)] += term;
        }
    }
}

/// The cosine below which a point is more than `angle` away (-2, no point, where `angle`
/// passes the antipode).
fn cos_within(angle: f64) -> f64 {
    if angle < std::f64::consts::PI {
        angle.cos()
    } else {
        -2.0
    }
}

/// The angle in [0, pi] whose sine and cosine are `sin_d` >= 0 and `cos_d`: atan(sin/cos)
/// where cos > 0 (every pair within a cut-off below 90 degrees), the same angle as atan2 to an
/// ulp and 15% off a torque evaluation; atan2 otherwise.
#[inline]
fn angle_from_sin_cos(sin_d: f64, cos_d: f64) -> f64 {
    if cos_d > 0.0 {
        (sin_d / cos_d).atan()
    } else {
        sin_d.atan2(cos_d)
    }
}

/// The motor as the torque model sees it: rotor magnets (body frame), stator coils (world
/// frame), the pair well and the interaction.
#[derive(Debug, Clone)]
pub struct MagnetTorques {
    /// The rotor magnets' positions (body frame), in magnet order.
    pub rotor: Vec<Vector3<f64>>,
    /// The stator coils' positions (world frame), in coil order.
    pub stator: Vec<Vector3<f64>>,
    /// The pull of one coil on one magnet against their angular distance.
    pub well: Well,
    /// Which magnets each energised coil pulls.
    pub interaction: Interaction,
}

impl MagnetTorques {
    /// Torque (world) and energy of one coil attracting one magnet at world position `p`.
    #[inline]
    fn pair(&self, p: &Vector3<f64>, s: &Vector3<f64>) -> (Vector3<f64>, f64) {
        let x = p.cross(s);
        let d = angle_from_sin_cos(x.norm(), p.dot(s));
        (self.well.pair_torque(p, s, -2.0), self.well.potential(d))
    }

    /// Adds one pair's body-frame torque and its derivative to `lin` (coil `s` and magnet `p`
    /// in the body frame): with u = p x s and c = p . s, N = f u and
    /// dN/d delta = f (s p^T - c 1) - (f'/sin d) u u^T. A magnet whose cosine is below
    /// `cos_far` ([`MagnetTorques::cos_far`]) is beyond the cut-off by more than the margin's
    /// cap and adds nothing. `None` without an analytic slope.
    #[inline]
    fn pair_linearization(
        &self,
        p: &Vector3<f64>,
        s: &Vector3<f64>,
        cos_far: f64,
        lin: &mut Linearization,
    ) -> Option<()> {
        let c = p.dot(s);
        if c < cos_far {
            return Some(());
        }
        let u = p.cross(s);
        let (f, slope) = match &self.well.profile {
            Some(profile) => {
                if c < self.well.cos_near {
                    // within the margin's cap of the cut-off: the angle matters
                    let d = angle_from_sin_cos(u.norm(), c);
                    lin.cutoff_margin = lin
                        .cutoff_margin
                        .min((d - self.well.max_attraction.0).abs());
                }
                // 0 beyond the cut-off, as the torque
                profile.value_and_slope(1.0 - c)
            }
            None => {
                let sin_d = u.norm();
                let d = angle_from_sin_cos(sin_d, c);
                lin.cutoff_margin = lin
                    .cutoff_margin
                    .min((d - self.well.max_attraction.0).abs());
                if d > self.well.max_attraction.0 {
                    return Some(());
                }
                self.well.f_and_slope(d, sin_d)?
            }
        };
        add_pair_terms(lin, p, s, &u, c, f, slope);
        Some(())
    }

    /// An empty linearization (the margin at its cap).
    fn no_linearization() -> Linearization {
        Linearization {
            torque: Vector3::zeros(),
            jacobian: Matrix3::zeros(),
            cutoff_margin: MARGIN_CAP,
        }
    }

    /// The "pairs" interaction's body-frame torque, each coil turned into the body frame by
    /// `to_body`: a few pairs, so the well's own cut-off test is cheaper than a cosine per call.
    #[inline(always)]
    fn pairs_body_torque(
        &self,
        active: &[Pair],
        to_body: impl Fn(&Vector3<f64>) -> Vector3<f64>,
    ) -> Vector3<f64> {
        let mut tau = Vector3::zeros();
        for pr in active {
            let s = to_body(&self.stator[pr.coil.0]);
            tau += self.well.pair_torque(&self.rotor[pr.magnet.0], &s, -2.0);
        }
        tau
    }

    /// The distinct coils of an active set, in order of first appearance.
    fn coils(active: &[Pair]) -> impl Iterator<Item = usize> + '_ {
        active
            .iter()
            .enumerate()
            .filter(|(k, p)| !active[..*k].iter().any(|o| o.coil == p.coil))
            .map(|(_, p)| p.coil.0)
    }
}

impl TorqueModel for MagnetTorques {
    fn torque_energy(&self, r: &Matrix3<f64>, active: &[Pair]) -> (Vector3<f64>, f64) {
        let mut tau = Vector3::zeros();
        let mut u = 0.0;
        match self.interaction {
            Interaction::Pairs => {
                for pr in active {
                    let p = r * self.rotor[pr.magnet.0];
                    let (t, e) = self.pair(&p, &self.stator[pr.coil.0]);
                    tau += t;
                    u += e;
                }
            }
            Interaction::Coils => {
                // a magnet beyond the cut-off by more than the margin's cap (a cheap body-frame
                // test) adds the well's constant energy there, the same bits as its pair's
                // (its torque is a zero, which leaves the sum as it is: the sum, from +0,
                // never holds a -0)
                let (cos_far, u_far) = (
                    self.well.cos_far,
                    self.well.potential(self.well.max_attraction.0),
                );
                for c in Self::coils(active) {
                    let s = self.stator[c];
                    let s_body = r.tr_mul(&s);
                    for m in &self.rotor {
                        if m.dot(&s_body) < cos_far {
                            u += u_far;
                            continue;
                        }
                        let (t, e) = self.pair(&(r * m), &s);
                        tau += t;
                        u += e;
                    }
                }
            }
        }
        (tau, u)
    }

    fn torque(&self, r: &Matrix3<f64>, active: &[Pair]) -> Vector3<f64> {
        r * self.body_torque(r, active)
    }

    /// The hot path: each energised coil is turned into the body frame once (R^T s) and the
    /// magnets are used where they are, so no magnet is rotated and nothing is allocated.
    fn body_torque(&self, r: &Matrix3<f64>, active: &[Pair]) -> Vector3<f64> {
        match self.interaction {
            Interaction::Pairs => self.pairs_body_torque(active, |s| r.tr_mul(s)),
            Interaction::Coils => {
                let mut tau = Vector3::zeros();
                let cos_cutoff = self.well.cos_cutoff;
                for c in Self::coils(active) {
                    let s = r.tr_mul(&self.stator[c]);
                    for m in &self.rotor {
                        tau += self.well.pair_torque(m, &s, cos_cutoff);
                    }
                }
                tau
            }
        }
    }

    fn body_torque_at(&self, q: &[f64; 4], active: &[Pair]) -> Vector3<f64> {
        match self.interaction {
            Interaction::Pairs => {
                let rot = QuaternionRotation::new(q);
                self.pairs_body_torque(active, |s| rot.to_body(s))
            }
            Interaction::Coils => {
                self.body_torque(&rotation_matrix(q[0], q[1], q[2], q[3]), active)
            }
        }
    }

    fn linearize(&self, r: &Matrix3<f64>, active: &[Pair]) -> Option<Linearization> {
        let mut lin = Self::no_linearization();
        let cos_far = self.well.cos_far;
        match self.interaction {
            Interaction::Pairs => {
                for pr in active {
                    let s = r.tr_mul(&self.stator[pr.coil.0]);
                    self.pair_linearization(&self.rotor[pr.magnet.0], &s, cos_far, &mut lin)?;
                }
            }
            Interaction::Coils => {
                for c in Self::coils(active) {
                    let s = r.tr_mul(&self.stator[c]);
                    for m in &self.rotor {
                        self.pair_linearization(m, &s, cos_far, &mut lin)?;
                    }
                }
            }
        }
        Some(lin)
    }

    fn stiffness_scale(&self) -> Option<f64> {
        match self.well.shape {
            WellShape::Table(_) => None,
            _ => Some(self.well.stiffness()),
        }
    }

    fn nearby<'s>(&'s self, r0: &Matrix3<f64>, active: &'s [Pair]) -> Option<NearbyMagnets<'s>> {
        (self.interaction == Interaction::Coils).then(|| NearbyMagnets::new(self, r0, active))
    }

    fn trusts_uncrossed_cutoffs(&self) -> bool {
        self.interaction == Interaction::Pairs
    }

    fn cutoff_events(&self, active: &[Pair]) -> bool {
        self.interaction == Interaction::Pairs
            && self.well.cutoff_jump
            && active.len() <= MAX_EVENT_PAIRS
    }

    fn body_torque_within(&self, q: &[f64; 4], active: &[Pair], within: SideMask) -> Vector3<f64> {
        if self.interaction != Interaction::Pairs {
            return self.body_torque_at(q, active);
        }
        let rot = QuaternionRotation::new(q);
        let mut tau = Vector3::zeros();
        for (i, pr) in active.iter().enumerate() {
            if within >> i & 1 == 1 {
                let s = rot.to_body(&self.stator[pr.coil.0]);
                tau += self
                    .well
                    .pair_torque_continued(&self.rotor[pr.magnet.0], &s);
            }
        }
        tau
    }

    fn cutoff_margins(
        &self,
        r: &Matrix3<f64>,
        w: &Vector3<f64>,
        active: &[Pair],
        out: &mut Vec<(f64, f64)>,
    ) -> bool {
        if self.interaction != Interaction::Pairs || !self.well.cutoff_jump {
            return false;
        }
        for pr in active {
            let s = r.tr_mul(&self.stator[pr.coil.0]);
            out.push(self.well.cutoff_margin(&self.rotor[pr.magnet.0], &s, w));
        }
        true
    }

    fn cutoff_margins_of(
        &self,
        r: &Matrix3<f64>,
        w: &Vector3<f64>,
        active: &[Pair],
        pairs: SideMask,
        out: &mut [(f64, f64)],
    ) -> bool {
        if self.interaction != Interaction::Pairs || !self.well.cutoff_jump {
            return false;
        }
        for i in set_bits(pairs & first_bits(active.len().min(out.len()))) {
            let pr = active[i];
            let s = r.tr_mul(&self.stator[pr.coil.0]);
            out[i] = self.well.cutoff_margin(&self.rotor[pr.magnet.0], &s, w);
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three coils around -Z and `magnets` magnets spread over the sphere, every coil pulling
    /// every magnet in reach of `well` (the "coils" interaction).
    fn three_coils(well: Well, magnets: usize) -> MagnetTorques {
        MagnetTorques {
            rotor: crate::io::scenario::sphere_axes(magnets)
                .iter()
                .map(|a| a.into_inner())
                .collect(),
            stator: vec![
                Vector3::new(0.0, 0.0, -1.0),
                Vector3::new(0.4, 0.1, -1.0).normalize(),
                Vector3::new(-0.2, 0.5, -1.0).normalize(),
            ],
            well,
            interaction: Interaction::Coils,
        }
    }

    fn wells() -> Vec<Well> {
        let table = TorqueTable::from_rows(&[
            (0.0, 0.0),
            (5.0, 0.4),
            (10.0, 0.6),
            (20.0, 0.5),
            (30.0, 0.0),
        ])
        .unwrap();
        vec![
            Well::new(
                WellShape::Gaussian {
                    strength_j: 0.2,
                    width: Radians(0.17),
                },
                Radians(0.5),
            ),
            Well::new(WellShape::Cosine { strength_j: 0.3 }, Radians(0.5)),
            Well::new(WellShape::Table(table), Radians(0.5)),
        ]
    }

    #[test]
    fn a_quaternion_rotation_turns_vectors_as_the_transposed_matrix_does() {
        // unnormalised, with every component nonzero, so each entry of M is exercised
        let (x, y, z, w) = (0.31, -0.72, 0.18, 1.9);
        let q = QuaternionRotation::new(&[x, y, z, w]);
        let r = rotation_matrix(x, y, z, w);
        let unit = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
        assert!((unit.to_rotation_matrix().matrix() - r).norm() < 1e-15);
        for v in [
            Vector3::x(),
            Vector3::y(),
            Vector3::z(),
            Vector3::new(0.3, -0.5, 0.8),
        ] {
            assert!((q.to_body(&v) - r.transpose() * v).norm() < 1e-15);
        }
    }

    #[test]
    fn g_is_the_slope_of_u() {
        for w in wells() {
            for i in 1..49 {
                let d = i as f64 * 0.01 + 0.0005;
                let h = 1e-6;
                let du = (w.potential(d + h) - w.potential(d - h)) / (2.0 * h);
                // the pull towards the coil has magnitude dU/dd (U rises away from the coil)
                assert!((w.g(d) - du).abs() < 1e-6, "{:?} at {d}", w.shape);
                assert!(w.g(d) >= 0.0);
                assert!((w.g_over_sin(d, d.sin()) * d.sin() - w.g(d)).abs() < 1e-12);
            }
            // cut-off: no torque, constant potential
            assert_eq!(w.g(0.6), 0.0);
            assert_eq!(w.potential(0.6), w.potential(0.7));
            // aligned: a finite factor equal to the stiffness
            let f = w.g_over_sin(0.0, 0.0);
            assert!(f.is_finite());
            assert!((f - w.stiffness()).abs() < 1e-9);
        }
    }

    #[test]
    fn pair_torque_pulls_the_magnet_towards_its_coil() {
        let w = wells().remove(0);
        let m = MagnetTorques {
            rotor: vec![Vector3::new(0.0, 0.2f64.sin(), -0.2f64.cos())],
            stator: vec![Vector3::new(0.0, 0.0, -1.0)],
            well: w.clone(),
            interaction: Interaction::Pairs,
        };
        let (t, e) = m.torque_energy(&Matrix3::identity(), &[Pair::new(0, 0)]);
        // p x s points along -x here; turning about it moves p towards s
        assert!(t.x < 0.0 && t.y.abs() < 1e-15 && t.z.abs() < 1e-15);
        assert!((t.norm() - w.g(0.2)).abs() < 1e-12);
        assert!((e - w.potential(0.2)).abs() < 1e-15);
        let p = m.rotor[0];
        let moved = p + t.cross(&p) * 1e-3;
        assert!(moved.normalize().dot(&m.stator[0]) > p.dot(&m.stator[0]));
    }

    #[test]
    fn only_a_well_whose_pull_jumps_at_its_cut_off_is_watched_for_grazes() {
        // the gaussian, cosine and table wells of `wells()` still pull at their cut-offs
        for w in wells() {
            assert!(w.jumps_at_cutoff(), "{:?}", w.shape());
        }
        // a table that ends at zero there does not: a graze changes nothing
        let table = TorqueTable::from_rows(&[(0.0, 0.0), (10.0, 0.5), (20.0, 0.0)]).unwrap();
        let w = Well::new(WellShape::Table(table), Radians(20f64.to_radians()));
        assert!(!w.jumps_at_cutoff());
        let m = MagnetTorques {
            rotor: vec![Vector3::new(0.0, 0.1f64.sin(), -0.1f64.cos())],
            stator: vec![Vector3::new(0.0, 0.0, -1.0)],
            well: w,
            interaction: Interaction::Pairs,
        };
        let mut out = Vec::new();
        let (r, w0) = (Matrix3::identity(), Vector3::zeros());
        assert!(!m.cutoff_margins(&r, &w0, &[Pair::new(0, 0)], &mut out));
        // the same pair in a well that jumps: its margin p . s - cos(d_max) and its rate
        let m = MagnetTorques {
            well: wells().remove(1),
            ..m
        };
        assert!(m.cutoff_margins(
            &r,
            &Vector3::new(1.0, 0.0, 0.0),
            &[Pair::new(0, 0)],
            &mut out
        ));
        assert_eq!(out.len(), 1);
        assert!((out[0].0 - (0.1f64.cos() - 0.5f64.cos())).abs() < 1e-15);
        // turning about +x moves the magnet away from the coil at -z: the margin falls
        assert!(out[0].1 < 0.0);
    }

    #[test]
    fn the_profiled_torques_are_the_formulas_and_end_at_the_cut_off() {
        let s = Vector3::new(0.0, 0.0, -1.0);
        let (mut smooth, mut kinked) = (0, 0);
        for w in wells() {
            // the table's kinks (and only they) leave it to its formula
            match w.shape() {
                WellShape::Table(_) => kinked += (!w.has_profile()) as usize,
                _ => smooth += w.has_profile() as usize,
            }
            for i in 0..=600 {
                let d = w.max_attraction().0 * (i as f64 / 500.0);
                let p = Vector3::new(d.sin(), 0.0, -d.cos());
                let formula = p.cross(&s) * w.g_over_sin(d, d.sin());
                let torque = w.pair_torque(&p, &s, -2.0);
                let scale = w.g(d).abs().max(1e-3 * w.stiffness() * 0.1);
                assert!(
                    (torque - formula).norm() <= 1e-12 * scale,
                    "{:?} at {d}: {torque} against {formula}",
                    w.shape()
                );
                if d > w.max_attraction().0 * (1.0 + 1e-9) {
                    assert_eq!(torque, Vector3::zeros());
                }
            }
        }
        assert_eq!((smooth, kinked), (2, 1));
    }

    #[test]
    fn the_linearization_is_the_torque_and_its_derivative() {
        // finite differences of the body torque under R -> R exp([delta]x), at orientations
        // where the pairs are 0 to 25 degrees from their coils (and one beyond the cut-off)
        let rotor = vec![
            Vector3::new(0.0, 0.3f64.sin(), -0.3f64.cos()),
            Vector3::new(0.2f64.sin(), 0.0, -0.2f64.cos()),
            Vector3::new(-0.3, -0.2, -0.9).normalize(),
        ];
        let stator = vec![
            Vector3::new(0.0, 0.0, -1.0),
            Vector3::new(0.1, 0.05, -1.0).normalize(),
            Vector3::new(-0.2, -0.3, -0.9).normalize(),
        ];
        let active = [Pair::new(0, 0), Pair::new(1, 1), Pair::new(2, 2)];
        for w in wells().into_iter().take(2) {
            let m = MagnetTorques {
                rotor: rotor.clone(),
                stator: stator.clone(),
                well: w,
                interaction: Interaction::Pairs,
            };
            let r = nalgebra::Rotation3::from_scaled_axis(Vector3::new(0.05, -0.1, 0.02));
            let lin = m.linearize(r.matrix(), &active).unwrap();
            assert!((lin.torque - m.body_torque(r.matrix(), &active)).norm() < 1e-12);
            let h = 1e-6;
            for k in 0..3 {
                let mut e = Vector3::zeros();
                e[k] = h;
                let plus = r * nalgebra::Rotation3::from_scaled_axis(e);
                let minus = r * nalgebra::Rotation3::from_scaled_axis(-e);
                let fd = (m.body_torque(plus.matrix(), &active)
                    - m.body_torque(minus.matrix(), &active))
                    / (2.0 * h);
                let col = lin.jacobian.column(k);
                assert!(
                    (fd - col).norm() < 1e-6 * (1.0 + fd.norm()),
                    "{fd} vs {col}"
                );
            }
            assert!(lin.cutoff_margin > 0.0 && lin.cutoff_margin < 0.5);
        }
        // a table has no analytic slope
        let m = MagnetTorques {
            rotor,
            stator,
            well: wells().remove(2),
            interaction: Interaction::Pairs,
        };
        assert!(m.linearize(&Matrix3::identity(), &active).is_none());
        assert!(m.stiffness_scale().is_none());
    }

    #[test]
    fn nearby_magnets_give_the_whole_models_torques_to_the_bit() {
        let active = [Pair::new(0, 3), Pair::new(2, 7), Pair::new(0, 9)];
        let r0 = nalgebra::Rotation3::from_scaled_axis(Vector3::new(0.3, -0.2, 0.5));
        for w in wells() {
            let m = three_coils(w, 200);
            let near = m.nearby(r0.matrix(), &active).unwrap();
            assert!(near.magnets.len() < 100, "{} of 400", near.magnets.len());
            // turns of 0 to 19.5 degrees (within the skin) and of 25 to 175 (beyond it: lists
            // built again at 25, 70, 120 and 175 degrees, the chain full at 150)
            for (k, deg) in [
                0.0f64, 0.5, 3.0, 8.0, 14.0, 19.5, 25.0, 70.0, 120.0, 175.0, 150.0,
            ]
            .into_iter()
            .enumerate()
            {
                let axis = Vector3::new(1.0, k as f64 - 3.0, 0.5 * k as f64).normalize();
                let r = r0 * nalgebra::Rotation3::from_scaled_axis(axis * deg.to_radians());
                let (a, b) = (
                    near.body_torque(r.matrix(), &active),
                    m.body_torque(r.matrix(), &active),
                );
                assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits), "{deg} deg");
                assert!(b.norm() > 0.0);
                assert_eq!(
                    near.linearize(r.matrix(), &active),
                    m.linearize(r.matrix(), &active)
                );
                assert_eq!(
                    near.torque_energy(r.matrix(), &active),
                    m.torque_energy(r.matrix(), &active)
                );
            }
            assert_eq!(near.rebuilds(), 4);
            // another active set: the whole model
            let other = [Pair::new(1, 0)];
            assert_eq!(
                near.body_torque(r0.matrix(), &other),
                m.body_torque(r0.matrix(), &other)
            );
        }
        // the pairs interaction has nothing to gain
        let m = MagnetTorques {
            interaction: Interaction::Pairs,
            ..three_coils(wells().remove(0), 20)
        };
        assert!(m.nearby(r0.matrix(), &active).is_none());
    }

    #[test]
    fn the_coils_energy_passes_over_far_magnets_to_the_bit() {
        // the whole "coils" sum of every pair, each magnet turned into the world frame
        let every_pair = |m: &MagnetTorques, r: &Matrix3<f64>, active: &[Pair]| {
            let (mut tau, mut u) = (Vector3::zeros(), 0.0);
            for c in MagnetTorques::coils(active) {
                for p in &m.rotor {
                    let (t, e) = m.pair(&(r * p), &m.stator[c]);
                    tau += t;
                    u += e;
                }
            }
            (tau, u)
        };
        let active = [Pair::new(0, 3), Pair::new(2, 7), Pair::new(0, 9)];
        for w in wells() {
            let m = three_coils(w, 150);
            for k in 0..12 {
                let axis = Vector3::new(1.0, k as f64 - 5.0, 0.3 * k as f64).normalize();
                let r = nalgebra::Rotation3::from_scaled_axis(axis * (0.4 * k as f64));
                let (tau, u) = m.torque_energy(r.matrix(), &active);
                let (tau_all, u_all) = every_pair(&m, r.matrix(), &active);
                assert_eq!(tau.map(f64::to_bits), tau_all.map(f64::to_bits), "turn {k}");
                assert_eq!(u.to_bits(), u_all.to_bits(), "turn {k}");
                assert!(tau.norm() > 0.0 && u < 0.0);
            }
        }
    }

    #[test]
    fn nearby_magnets_hold_their_cut_offs_as_events() {
        let m = three_coils(wells().remove(1), 80);
        let active = [Pair::new(0, 3), Pair::new(2, 7)];
        let r0 = nalgebra::Rotation3::from_scaled_axis(Vector3::new(0.3, -0.2, 0.5));
        let near = m.nearby(r0.matrix(), &active).unwrap();
        let n = near.magnets.len();
        assert!(n > 2 && n <= MAX_EVENT_PAIRS, "{n} nearby magnets");
        assert!(near.cutoff_events(&active) && !near.cutoff_events(&active[..1]));
        assert!(
            !m.cutoff_events(&active),
            "the whole coils model has no events"
        );
        // 10 degrees within the skin: the magnets within reach pull as the whole model's, to the bit
        let turn = nalgebra::UnitQuaternion::from_scaled_axis(Vector3::new(0.1, 0.12, -0.05));
        let q = (nalgebra::UnitQuaternion::from_rotation_matrix(&r0) * turn).into_inner();
        let q = [q.i, q.j, q.k, q.w];
        let r = rotation_matrix(q[0], q[1], q[2], q[3]);
        let mut margins = Vec::new();
        assert!(near.cutoff_margins(&r, &Vector3::zeros(), &active, &mut margins));
        assert_eq!(margins.len(), n);
        let within = within_reach(&margins);
        let whole = m.body_torque(&r, &active);
        let bits = |v: Vector3<f64>| v.map(f64::to_bits);
        assert_eq!(
            bits(near.body_torque_within(&q, &active, within)),
            bits(whole)
        );
        // a magnet of coil 0 beyond its cut-off held within reach pulls by the continued formula
        let i = (0..near.starts[1]).find(|&i| margins[i].0 < 0.0).unwrap();
        let s = r.tr_mul(&m.stator[0]);
        let pull = m.well.pair_torque_continued(&near.magnets[i], &s);
        assert!(pull.norm() > 1e-3 * whole.norm());
        let held = near.body_torque_within(&q, &active, within | 1 << i);
        assert!(
            (held - whole - pull).norm() < 1e-12,
            "{held} against {whole} + {pull}"
        );
        // beyond the skin (30 degrees): the whole model's torque, whatever the bits
        let far = nalgebra::UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.0, 0.52));
        let q = (nalgebra::UnitQuaternion::from_rotation_matrix(&r0) * far).into_inner();
        let q = [q.i, q.j, q.k, q.w];
        let r = rotation_matrix(q[0], q[1], q[2], q[3]);
        assert_eq!(
            bits(near.body_torque_within(&q, &active, SideMask::MAX)),
            bits(m.body_torque(&r, &active))
        );
    }

    #[test]
    fn nearby_magnets_carry_their_sides_to_lists_built_beyond_the_skin() {
        let m = three_coils(wells().remove(1), 80);
        let active = [Pair::new(0, 3), Pair::new(2, 7)];
        let r0 = nalgebra::Rotation3::from_scaled_axis(Vector3::new(0.3, -0.2, 0.5));
        let near = m.nearby(r0.matrix(), &active).unwrap();
        let sides = |lists: &NearbyMagnets<'_>, r: &Matrix3<f64>| {
            let mut margins = Vec::new();
            assert!(lists.cutoff_margins(r, &Vector3::zeros(), &active, &mut margins));
            let within = within_reach(&margins);
            (within, margins)
        };
        // 19 degrees from r0, at the skin's edge: the lists built there hold other magnets
        let turn = Vector3::new(0.6, -0.3, 0.74).normalize() * 19f64.to_radians();
        let r = (r0 * nalgebra::Rotation3::from_scaled_axis(turn)).into_inner();
        let (within, _) = sides(&near, &r);
        assert!(within.count_ones() >= 2, "{within:b}");
        let (next, carried) = near.continued_at(&r, &active, within).unwrap();
        assert_ne!(next.ids, near.ids, "the same lists");
        // the pairs within reach are those within reach, pair by pair
        let (within_next, margins) = sides(&next, &r);
        assert_eq!(carried, within_next);
        assert_eq!(carried.count_ones(), within.count_ones());
        // the sides are carried over by (coil, magnet), not taken from the margins: a pair
        // held within reach beyond its cut-off stays held on the new lists
        let (i, j) = (0..near.starts[1])
            .find_map(|i| {
                let j = (0..next.starts[1]).find(|&j| next.ids[j] == near.ids[i])?;
                (within >> i & 1 == 0).then_some((i, j))
            })
            .unwrap();
        assert!(margins[j].0 < 0.0);
        let (_, held) = near.continued_at(&r, &active, within | 1 << i).unwrap();
        assert_eq!(held, carried | 1 << j);
        // the chain ends after MAX_REBUILDS lists, another active set has none
        let mut lists = next;
        for depth in 2..=5 {
            let (within, _) = sides(&lists, &r);
            match lists.continued_at(&r, &active, within) {
                Some((deeper, _)) => lists = deeper,
                None => {
                    assert_eq!(depth, 5);
                    break;
                }
            }
            assert!(depth < 5, "a fifth rebuild");
        }
        assert!(near.continued_at(&r, &active[..1], 0).is_none());
        // beyond the skin (90 degrees) magnets the lists left out are within reach: the skin's
        // promise fails, and the settle may not go on on such lists
        let far = (r0 * nalgebra::Rotation3::from_scaled_axis(turn * 90.0 / 19.0)).into_inner();
        assert!(near.continued_at(&far, &active, 0).is_none());
        let (fresh, _) = sides(&m.nearby(&far, &active).unwrap(), &far);
        assert!(fresh != 0, "no magnet within reach at 90 degrees");
    }

    #[test]
    fn a_pairs_terms_are_nalgebras_to_the_bit() {
        // the terms by nalgebra's matrix expressions, as the linearization summed them before
        fn by_matrices(
            lin: &mut Linearization,
            (p, s, u): (&Vector3<f64>, &Vector3<f64>, &Vector3<f64>),
            (c, f, slope): (f64, f64, f64),
        ) {
            lin.torque += u * f;
            lin.jacobian +=
                (s * p.transpose() - Matrix3::identity() * c) * f - u * u.transpose() * slope;
        }
        let mut rng = crate::model::random::SplitMix::new(5);
        let mut unit = |zeros: bool| {
            let mut r = || 2.0 * rng.uniform() - 1.0;
            let mut v = Vector3::new(r(), r(), r()).normalize();
            if zeros {
                // exact and signed zeros, which only the order of the operations keeps
                v[(rng.uniform() * 3.0) as usize % 3] =
                    if rng.uniform() < 0.5 { 0.0 } else { -0.0 };
            }
            v
        };
        for k in 0..20_000 {
            let (p, s) = (unit(k % 3 == 0), unit(k % 5 == 0));
            let u = p.cross(&s);
            let c = p.dot(&s);
            let (f, slope) = (1.0 + c * 0.37, if k % 7 == 0 { 0.0 } else { -2.5 * c });
            let start = Linearization {
                torque: Vector3::new(0.1, -0.2, 0.0),
                jacobian: Matrix3::new(0.0, -0.0, 1.0, 2.0, -3.0, 0.0, -0.0, 0.5, 0.25),
                cutoff_margin: MARGIN_CAP,
            };
            let (mut a, mut b) = (start, start);
            add_pair_terms(&mut a, &p, &s, &u, c, f, slope);
            by_matrices(&mut b, (&p, &s, &u), (c, f, slope));
            let bits = |l: &Linearization| {
                let mut v: Vec<u64> = l.torque.iter().map(|x| x.to_bits()).collect();
                v.extend(l.jacobian.iter().map(|x| x.to_bits()));
                v
            };
            assert_eq!(bits(&a), bits(&b), "p {p:?} s {s:?}");
        }
    }

    #[test]
    fn bad_tables_are_rejected_with_the_row() {
        let e = TorqueTable::from_rows(&[(0.0, 0.0), (5.0, f64::NAN)]).unwrap_err();
        assert!(e.contains("row 2") && e.contains("finite"), "{e}");
        // a repulsion is physics, not an error
        assert!(TorqueTable::from_rows(&[(0.0, 0.0), (5.0, 1.0), (20.0, -0.1)]).is_ok());
        let e = TorqueTable::from_rows(&[(0.0, 0.0), (5.0, 1.0), (5.0, 1.0)]).unwrap_err();
        assert!(e.contains("row 3") && e.contains("increasing"), "{e}");
        let e = TorqueTable::from_rows(&[(1.0, 0.0), (5.0, 1.0)]).unwrap_err();
        assert!(e.contains("0 degrees"), "{e}");
    }
}
