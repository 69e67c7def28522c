//! Physical magnets (the "dipole" well shape of docs/model.md): the torque on the rotor from
//! magnet and coil specifications instead of a fitted well.
//!
//! - Rotor magnets are point dipoles (moment `m`, pointing radially outward, at the ball's
//!   radius); stator coils are circular current loops of `N I` ampere-turns, optionally with a
//!   core gain on their field.
//! - The loop's field is the exact one (complete elliptic integrals, by the arithmetic-geometric
//!   mean), with the dipole far field beyond [`FAR_FIELD_SWITCH`] loop radii; the force on a
//!   magnet is `grad(m . B)` from the field's analytic Jacobian.
//! - Point-dipole helpers (field, Jacobian, force, torque between two dipoles).
//! - [`DipoleParts`] (the plain data of the motor's parts), [`torque_on_magnet`] (the 3-D
//!   torque of one coil on one magnet about the rotor centre) and its reduction to a pair well,
//!   [`DipoleWell`]: `tau = g(d) (p x s) / |p x s|`, `g = dU/dd`, `U = -m . B`.
//!
//! SI units throughout (m, T, A, A m^2, N, N m, J); the world frame has its origin at the rotor
//! centre.

use crate::physics::real_parts::{RealParts, WellTable};
use nalgebra::{Matrix3, Unit, Vector3};
use std::f64::consts::{FRAC_PI_2, PI};
use std::sync::Arc;

/// The vacuum permeability mu0 = 4 pi 1e-7 T m / A (the pre-2019 exact value; the SI value
/// differs by 1e-10 relative).
pub const MU0: f64 = 4.0 * PI * 1e-7;

/// mu0 / (4 pi), T m / A.
const MU0_OVER_4PI: f64 = 1e-7;

/// Distance from a loop's centre, in loop radii, at and beyond which its field is the dipole
/// far field.
///
/// Outside r = a the loop's scalar potential is a sum of odd multipoles; after the dipole
/// (l = 1) the next is the octupole (l = 3), with on-axis field
/// `B = mu0 N I a^2 / (2 z^3) (1 - (3/2) (a/z)^2 + (15/8) (a/z)^4 - ...)`, i.e. multipole
/// coefficients A_1 = N I a^2 / 4 and A_3 = -(3/16) N I a^4. The octupole's field relative
/// to the dipole's is `(3/4) (a/r)^2 sqrt(16 P3^2 + sin^2(t) P3'^2) / sqrt(1 + 3 cos^2 t)`
/// at polar angle t, whose maximum over t is 2, on the axis: the far field's relative error
/// is `(3/2) (a/r)^2 + O((a/r)^4)` at most. Below 1e-4 needs r/a > sqrt(15000) = 122.5; at
/// 130 the bound is 8.9e-5 (on the axis, exactly `(1 + (a/r)^2)^(3/2) - 1` = 8.876e-5), an 11%
/// margin. (For the prototype, magnets are at most ~16 coil radii from a coil: the exact field
/// is what they feel.)
pub const FAR_FIELD_SWITCH: f64 = 130.0;

/// Below this parameter m the loop's `H(m)` (see [`loop_field_cylindrical`]) is summed as a
/// power series (whose terms shrink like m^n: 0.3^43 < 1e-22 by the last); above it the closed
/// form loses at most ~1e-14 to cancellation.
const H_SERIES_BELOW: f64 = 0.3;

/// Complete elliptic integrals of the first and second kind, `(K(m), E(m))`, of the
/// PARAMETER `m = k^2` (not the modulus k): `K = int_0^{pi/2} (1 - m sin^2 t)^(-1/2) dt`,
/// `E = int_0^{pi/2} (1 - m sin^2 t)^(1/2) dt`, by the arithmetic-geometric mean (full double
/// precision). `m < 1` (negative m is fine); `m = 1` gives `(inf, 1)`, `m > 1` or NaN gives NaN.
pub fn elliptic_ke(m: f64) -> (f64, f64) {
    elliptic_ke_complement(m, 1.0 - m)
}

/// [`elliptic_ke`] with the complementary parameter `mc = 1 - m` given (accurate where m is
/// close to 1, i.e. near a loop's wire).
fn elliptic_ke_complement(m: f64, mc: f64) -> (f64, f64) {
    if m.is_nan() || mc.is_nan() || mc < 0.0 {
        return (f64::NAN, f64::NAN);
    }
    if mc == 0.0 {
        return (f64::INFINITY, 1.0);
    }
    // a_0 = 1, b_0 = sqrt(1 - m), c_0^2 = m; c_{n+1} = (a_n - b_n) / 2 = c_n^2 / (4 a_{n+1});
    // K = pi / (2 a_inf), E = K (1 - sum_n 2^(n-1) c_n^2).
    let (mut a, mut b) = (1.0_f64, mc.sqrt());
    let mut c2 = m;
    let mut weight = 0.5;
    let mut sum = weight * c2;
    for _ in 0..64 {
        let a1 = 0.5 * (a + b);
        b = (a * b).sqrt();
        c2 = c2 * c2 / (16.0 * a1 * a1);
        a = a1;
        weight *= 2.0;
        sum += weight * c2;
        if c2 <= (f64::EPSILON * a) * (f64::EPSILON * a) {
            break;
        }
    }
    let k = PI / (2.0 * a);
    (k, k * (1.0 - sum))
}

/// `H(m) = F(m) / m^2` with `F = (2 - m) E - 2 (1 - m) K`, which is `(3 pi / 16) m^2 + ...`,
/// and `m H'(m)`: a power series below [`H_SERIES_BELOW`] (the closed form cancels there), the
/// closed form above, where `F' = 3 (K - E) / 2` gives `m H' = F' / m - 2 H`.
fn h_and_slope(m: f64, k: f64, e: f64) -> (f64, f64) {
    if m.abs() >= H_SERIES_BELOW {
        let h = ((2.0 - m) * e - 2.0 * (1.0 - m) * k) / (m * m);
        return (h, 1.5 * (k - e) / m - 2.0 * h);
    }
    // K = pi/2 sum c_n m^n, E = pi/2 sum e_n m^n with c_n = ((2n-1)!! / (2n)!!)^2 and
    // e_n = -c_n / (2n - 1); F = pi/2 sum_{n>=2} (2 e_n - e_{n-1} - 2 c_n + 2 c_{n-1}) m^n.
    let (mut c_prev, mut e_prev) = (0.25, -0.25); // c_1, e_1
    let (mut sum, mut slope) = (0.0, 0.0);
    let mut power = 1.0; // m^(n-2)
    for n in 2..=45 {
        let nf = n as f64;
        let r = (2.0 * nf - 1.0) / (2.0 * nf);
        let c = c_prev * r * r;
        let e = -c / (2.0 * nf - 1.0);
        let term = (2.0 * e - e_prev - 2.0 * c + 2.0 * c_prev) * power;
        sum += term;
        slope += (nf - 2.0) * term;
        if n > 3 && term.abs() <= 1e-18 * sum.abs() {
            break;
        }
        c_prev = c;
        e_prev = e;
        power *= m;
    }
    (FRAC_PI_2 * sum, FRAC_PI_2 * slope)
}

/// A loop's field in its cylindrical frame and its derivatives along the axis.
struct CylindricalField {
    /// B_rho / rho, T/m
    q: f64,
    /// B_z, T
    bz: f64,
    /// d(B_rho / rho)/dz, T/m^2
    dq_dz: f64,
    /// dB_z/dz, T/m
    dbz_dz: f64,
}

/// [`loop_field_cylindrical`] with its analytic z-derivatives. With `dm/dz = -2 z m / beta^2`,
/// `dE/dm = (E - K) / (2 m)` and `W = 2 a^2 E - 8 a^2 rho^2 H / beta^2` (so that
/// `B_z = C W / (2 alpha^2 beta)`): `dW/dz = 2 a^2 z (K - E) / beta^2 + 16 a^2 rho^2 z
/// (m H' + H) / beta^4`, and `d(B_rho/rho)/dz = P (H - 2 z^2 m H' / beta^2) - (B_rho/rho) z
/// (2 / alpha^2 + 3 / beta^2)` with `P = 4 C a^2 / (alpha^2 beta^3)`.
fn loop_field_cylindrical_dz(a: f64, ni: f64, rho: f64, z: f64) -> CylindricalField {
    let alpha2 = (a - rho) * (a - rho) + z * z;
    let beta2 = (a + rho) * (a + rho) + z * z;
    let beta = beta2.sqrt();
    let m = 4.0 * a * rho / beta2;
    let (k, e) = elliptic_ke_complement(m, alpha2 / beta2);
    let (h, m_dh) = h_and_slope(m, k, e);
    let c = MU0 * ni / PI;
    let a2 = a * a;
    let pre_q = 4.0 * c * a2 / (alpha2 * beta2 * beta);
    let q = pre_q * z * h;
    let pre_z = c / (2.0 * alpha2 * beta);
    let w = 2.0 * a2 * e - 8.0 * a2 * rho * rho * h / beta2;
    let bz = pre_z * w;
    let dq_dz = pre_q * (h - 2.0 * z * z * m_dh / beta2) - q * z * (2.0 / alpha2 + 3.0 / beta2);
    let dw_dz =
        2.0 * a2 * z * (k - e) / beta2 + 16.0 * a2 * rho * rho * z * (m_dh + h) / (beta2 * beta2);
    let dbz_dz = pre_z * dw_dz - bz * z * (2.0 / alpha2 + 1.0 / beta2);
    CylindricalField {
        q,
        bz,
        dq_dz,
        dbz_dz,
    }
}

/// The exact field of a circular current loop in its own cylindrical coordinates: radius
/// `a` (m), ampere-turns `ni` (A, times any gain), at distance `rho >= 0` from the axis and
/// height `z` above the loop's plane. Returns `(B_rho / rho, B_z)` in T/m and T: `B_rho / rho`
/// is smooth on the axis (no division by rho), so `B = (B_rho / rho) rho_vec + B_z n`.
///
/// With `alpha^2 = (a - rho)^2 + z^2`, `beta^2 = (a + rho)^2 + z^2`, `m = k^2 = 4 a rho / beta^2`
/// and `C = mu0 N I / pi` the usual closed form (e.g. Simpson et al., NASA/TM-2013-217919) is
/// `B_rho = C z / (2 alpha^2 beta rho) [(a^2 + r^2) E - alpha^2 K]`,
/// `B_z = C / (2 alpha^2 beta) [(a^2 - r^2) E + alpha^2 K]`; rewritten with
/// `(a^2 + r^2) E - alpha^2 K = beta^2 F(m) / 2` it is
/// `B_rho / rho = 4 C z a^2 H(m) / (alpha^2 beta^3)`, `B_z = C / (2 alpha^2 beta) [2 a^2 E -
/// beta^2 m^2 H(m) / 2]`, well conditioned on and near the axis and far away. Singular only on
/// the wire (alpha = 0).
pub fn loop_field_cylindrical(a: f64, ni: f64, rho: f64, z: f64) -> (f64, f64) {
    let f = loop_field_cylindrical_dz(a, ni, rho, z);
    (f.q, f.bz)
}

/// The field of a point dipole of moment `moment` (A m^2) at offset `r` (m) from it (Jackson,
/// Classical Electrodynamics, 3rd ed., eq. 5.56, without the contact term at r = 0):
/// `B = mu0 / (4 pi) [3 n (n . m) - m] / |r|^3`, n = r / |r|. Singular at r = 0.
pub fn dipole_field(moment: &Vector3<f64>, r: &Vector3<f64>) -> Vector3<f64> {
    let r2 = r.norm_squared();
    let inv_r3 = 1.0 / (r2 * r2.sqrt());
    MU0_OVER_4PI * inv_r3 * (3.0 * r * (r.dot(moment) / r2) - moment)
}

/// The Jacobian dB_i/dr_j of [`dipole_field`] (T/m), the gradient of Jackson 5.56:
/// `3 mu0 / (4 pi r^5) [(m . r) I + r m^T + m r^T - 5 (m . r) r r^T / r^2]` (symmetric and
/// traceless: curl B = div B = 0).
pub fn dipole_field_jacobian(moment: &Vector3<f64>, r: &Vector3<f64>) -> Matrix3<f64> {
    let r2 = r.norm_squared();
    let mr = moment.dot(r);
    let scale = 3.0 * MU0_OVER_4PI / (r2 * r2 * r2.sqrt());
    scale
        * (Matrix3::from_diagonal_element(mr) + r * moment.transpose() + moment * r.transpose()
            - (5.0 * mr / r2) * r * r.transpose())
}

/// The force (N) on dipole `m2` at `x2` from dipole `m1` at `x1`, `grad(m2 . B1)`: with
/// `n = (x2 - x1) / r`, `F = 3 mu0 / (4 pi r^4) [(n . m1) m2 + (n . m2) m1 + (m1 . m2) n -
/// 5 (n . m1) (n . m2) n]` (the gradient of Jackson 5.56; e.g. K. W. Yung, P. B. Landecker,
/// D. D. Villani, Magn. Electr. Sep. 9 (1998) 39). Its reaction on `m1` is `-F`.
pub fn dipole_force(
    m1: &Vector3<f64>,
    x1: &Vector3<f64>,
    m2: &Vector3<f64>,
    x2: &Vector3<f64>,
) -> Vector3<f64> {
    let r = x2 - x1;
    let dist = r.norm();
    let n = r / dist;
    let (a, b) = (n.dot(m1), n.dot(m2));
    let scale = 3.0 * MU0_OVER_4PI / (dist * dist * dist * dist);
    scale * (a * m2 + b * m1 + m1.dot(m2) * n - 5.0 * a * b * n)
}

/// The torque (N m) on dipole `m2` at `x2` from dipole `m1` at `x1`, about `x2`:
/// `m2 x B1(x2)`, B1 by Jackson 5.56.
pub fn dipole_torque(
    m1: &Vector3<f64>,
    x1: &Vector3<f64>,
    m2: &Vector3<f64>,
    x2: &Vector3<f64>,
) -> Vector3<f64> {
    m2.cross(&dipole_field(m1, &(x2 - x1)))
}

/// A circular current loop (a coil of N turns, thin-wire model).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurrentLoop {
    /// Centre of the loop, m (world frame).
    pub centre: Vector3<f64>,
    /// Unit normal of the loop's plane: the direction of its moment for a positive current.
    pub axis: Unit<Vector3<f64>>,
    /// Mean radius a, m (> 0).
    pub radius_m: f64,
    /// Ampere-turns N I, A (signed).
    pub turns_amps: f64,
    /// Core gain (>= 1): multiplies the loop's moment and field.
    pub gain: f64,
}

/// Where a point lies relative to a loop: height z along the axis, the vector rho_vec from the
/// axis (perpendicular to it), its length rho and its direction (any perpendicular on the axis).
struct LoopCoordinates {
    z: f64,
    rho_vec: Vector3<f64>,
    rho: f64,
    e_rho: Vector3<f64>,
}

impl CurrentLoop {
    /// The loop's magnetic moment `gain N I pi a^2 axis`, A m^2.
    pub fn moment(&self) -> Vector3<f64> {
        self.gain * self.turns_amps * PI * self.radius_m * self.radius_m * self.axis.into_inner()
    }

    /// The distance from the centre at and beyond which [`CurrentLoop::field`] is the dipole
    /// far field: [`FAR_FIELD_SWITCH`] `* a`, m.
    pub fn switch_distance(&self) -> f64 {
        FAR_FIELD_SWITCH * self.radius_m
    }

    /// Whether [`CurrentLoop::field`] uses the far field at `x`.
    pub fn uses_far_field(&self, x: &Vector3<f64>) -> bool {
        (x - self.centre).norm() >= self.switch_distance()
    }

    fn coordinates(&self, x: &Vector3<f64>) -> LoopCoordinates {
        let n = self.axis.into_inner();
        let v = x - self.centre;
        let z = v.dot(&n);
        let rho_vec = v - z * n;
        let rho = rho_vec.norm();
        let e_rho = if rho > 0.0 {
            rho_vec / rho
        } else {
            perpendicular(&n)
        };
        LoopCoordinates {
            z,
            rho_vec,
            rho,
            e_rho,
        }
    }

    /// The loop's field at `x` (T): exact within [`CurrentLoop::switch_distance`], the dipole
    /// far field beyond (relative error below 1e-4 there).
    pub fn field(&self, x: &Vector3<f64>) -> Vector3<f64> {
        if self.uses_far_field(x) {
            self.field_far(x)
        } else {
            self.field_exact(x)
        }
    }

    /// The exact field (T) at `x` (elliptic integrals); finite everywhere but on the wire.
    pub fn field_exact(&self, x: &Vector3<f64>) -> Vector3<f64> {
        let c = self.coordinates(x);
        let ni = self.gain * self.turns_amps;
        let (q, bz) = loop_field_cylindrical(self.radius_m, ni, c.rho, c.z);
        q * c.rho_vec + bz * self.axis.into_inner()
    }

    /// The dipole far field (T) at `x` of the loop's moment.
    pub fn field_far(&self, x: &Vector3<f64>) -> Vector3<f64> {
        dipole_field(&self.moment(), &(x - self.centre))
    }

    /// The field (T) and its Jacobian dB_i/dx_j (T/m) at `x`, consistent with
    /// [`CurrentLoop::field`]: the far field's analytic Jacobian beyond the switch, the exact
    /// field's within it (see [`CurrentLoop::field_and_jacobian_exact`]).
    pub fn field_and_jacobian(&self, x: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
        if self.uses_far_field(x) {
            let r = x - self.centre;
            let moment = self.moment();
            (
                dipole_field(&moment, &r),
                dipole_field_jacobian(&moment, &r),
            )
        } else {
            self.field_and_jacobian_exact(x)
        }
    }

    /// The exact field (T) and its analytic Jacobian (T/m) at `x`. In the loop's cylindrical
    /// frame it is `dBr/dr e_r e_r^T + (Br/r) e_phi e_phi^T + dBr/dz (e_r n^T + n e_r^T) +
    /// dBz/dz n n^T`: dBr/dz and dBz/dz are the closed-form z-derivatives (see
    /// [`loop_field_cylindrical`]) and free space gives the rest, dBz/dr = dBr/dz (curl B = 0)
    /// and dBr/dr = -dBz/dz - Br/r (div B = 0). Built in the point's own frame, it rotates
    /// with the loop to rounding.
    pub fn field_and_jacobian_exact(&self, x: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
        let c = self.coordinates(x);
        let ni = self.gain * self.turns_amps;
        let n = self.axis.into_inner();
        let f = loop_field_cylindrical_dz(self.radius_m, ni, c.rho, c.z);
        let dbr_dz = c.rho * f.dq_dz;
        let dbr_dr = -f.dbz_dz - f.q;
        let err = c.e_rho * c.e_rho.transpose();
        let nnt = n * n.transpose();
        let ephi = Matrix3::identity() - err - nnt;
        let mixed = c.e_rho * n.transpose() + n * c.e_rho.transpose();
        let jac = dbr_dr * err + f.q * ephi + dbr_dz * mixed + f.dbz_dz * nnt;
        (f.q * c.rho_vec + f.bz * n, jac)
    }

    /// `grad(m . B)` at `x` for a constant moment `m` (the force on a dipole, N):
    /// `J^T m` (= `J m`, J being symmetric in free space).
    pub fn grad_m_dot_b(&self, x: &Vector3<f64>, m: &Vector3<f64>) -> Vector3<f64> {
        self.field_and_jacobian(x).1.transpose() * m
    }
}

/// A unit vector perpendicular to the unit vector `n`.
fn perpendicular(n: &Vector3<f64>) -> Vector3<f64> {
    let helper = if n.x.abs() < 0.6 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let v = helper - n.dot(&helper) * n;
    v / v.norm()
}

/// The moment (A m^2) of a uniformly magnetised magnet of remanence `br_t` (T) and volume
/// `volume_m3` (m^3): `Br V / mu0`.
pub fn magnet_moment_from_remanence(br_t: f64, volume_m3: f64) -> f64 {
    br_t * volume_m3 / MU0
}

/// The volume (m^3) of a disc (cylinder) magnet of the given diameter and thickness (m).
pub fn disc_volume(diameter_m: f64, thickness_m: f64) -> f64 {
    0.25 * PI * diameter_m * diameter_m * thickness_m
}

/// The physical parts of a spherical stepper, as the "dipole" well shape sees them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DipoleParts {
    /// Radius at which the magnets' centres sit (the ball's radius), m.
    pub ball_radius_m: f64,
    /// Moment of one rotor magnet, A m^2 (pointing radially outward).
    pub magnet_moment_am2: f64,
    /// Ampere-turns N I of an energised coil, A (negative: the coil repels).
    pub coil_turns_amps: f64,
    /// Mean radius a of a coil's winding, m.
    pub coil_radius_m: f64,
    /// Distance from the ball's surface (radius `ball_radius_m`) to a coil's plane, m.
    pub gap_m: f64,
    /// Gain (>= 1) of a coil's core on its moment and field (1: an air coil).
    pub core_gain: f64,
}

impl DipoleParts {
    /// Parts whose magnet is given by its remanence `br_t` (T) and volume `magnet_volume_m3`
    /// (m^3) instead of its moment; validated.
    pub fn from_remanence(
        ball_radius_m: f64,
        br_t: f64,
        magnet_volume_m3: f64,
        coil_turns_amps: f64,
        coil_radius_m: f64,
        gap_m: f64,
        core_gain: f64,
    ) -> Result<Self, String> {
        positive("br_t", br_t, "a positive finite remanence (T)")?;
        positive(
            "magnet_volume_m3",
            magnet_volume_m3,
            "a positive finite volume (m^3)",
        )?;
        let parts = DipoleParts {
            ball_radius_m,
            magnet_moment_am2: magnet_moment_from_remanence(br_t, magnet_volume_m3),
            coil_turns_amps,
            coil_radius_m,
            gap_m,
            core_gain,
        };
        parts.validate()?;
        Ok(parts)
    }

    /// An estimate of the paper's prototype (its exact parts were not published): a 12 inch
    /// ball, NdFeB N42 discs 0.75 x 0.25 inch (Br = 1.3 T, m = 1.87 A m^2), air coils of 2 inch
    /// outer diameter taken as a = 0.02 m mean radius, 500 turns at 2 A, 0.01 m gap.
    pub fn prototype() -> Self {
        let inch = 0.0254;
        DipoleParts {
            ball_radius_m: 0.1524,
            magnet_moment_am2: magnet_moment_from_remanence(
                1.3,
                disc_volume(0.75 * inch, 0.25 * inch),
            ),
            coil_turns_amps: 500.0 * 2.0,
            coil_radius_m: 0.02,
            gap_m: 0.01,
            core_gain: 1.0,
        }
    }

    /// Checks every field; the error names the offending field and what was expected.
    pub fn validate(&self) -> Result<(), String> {
        positive(
            "ball_radius_m",
            self.ball_radius_m,
            "a positive finite radius (m)",
        )?;
        positive(
            "magnet_moment_am2",
            self.magnet_moment_am2,
            "a positive finite moment (A m^2)",
        )?;
        if !self.coil_turns_amps.is_finite() {
            return Err(format!(
                "coil_turns_amps: expected finite ampere-turns N I (A), got {}",
                crate::text::shown(self.coil_turns_amps)
            ));
        }
        positive(
            "coil_radius_m",
            self.coil_radius_m,
            "a positive finite radius (m)",
        )?;
        if !(self.gap_m >= 0.0 && self.gap_m.is_finite()) {
            return Err(format!(
                "gap_m: expected a finite gap >= 0 (m), got {}",
                crate::text::shown(self.gap_m)
            ));
        }
        if !(self.core_gain >= 1.0 && self.core_gain.is_finite()) {
            return Err(format!(
                "core_gain: expected a finite gain >= 1, got {}",
                crate::text::shown(self.core_gain)
            ));
        }
        Ok(())
    }

    /// The coil on the unit axis `s` (world frame), energised: centred at
    /// `(ball_radius + gap) s`, its moment along `+s` (away from the ball).
    pub fn coil(&self, s: &Unit<Vector3<f64>>) -> CurrentLoop {
        CurrentLoop {
            centre: (self.ball_radius_m + self.gap_m) * s.into_inner(),
            axis: *s,
            radius_m: self.coil_radius_m,
            turns_amps: self.coil_turns_amps,
            gain: self.core_gain,
        }
    }
}

fn positive(name: &str, value: f64, expected: &str) -> Result<(), String> {
    if value > 0.0 && value.is_finite() {
        Ok(())
    } else {
        Err(format!(
            "{name}: expected {expected}, got {}",
            crate::text::shown(value)
        ))
    }
}

/// The grid step (rad) of a well's scans for its peak and reach: a 64th of its angular scale,
/// the closest the magnets (on radius `r`) come to a loop of radius `a` whose plane is `gap`
/// beyond them, seen from the centre (`sqrt(D^2 + a^2) - R` without the cancellation), within
/// [pi / 200000, pi / 1024].
fn scan_step(r: f64, a: f64, gap: f64) -> f64 {
    let wire = (r + gap).hypot(a);
    let scale = ((gap * (2.0 * r + gap) + a * a) / (wire + r) / r).min(1.0);
    (PI / 1024.0).min(scale / 64.0).max(PI / 200_000.0)
}

/// The magnet on `p` (position `R p`, moment `m p`) and the coil on `s`, both normalised here
/// (a zero vector gives NaN).
fn magnet_and_coil(
    parts: &DipoleParts,
    p: &Vector3<f64>,
    s: &Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>, CurrentLoop) {
    let p = p / p.norm();
    let coil = parts.coil(&Unit::new_unchecked(s / s.norm()));
    (parts.ball_radius_m * p, parts.magnet_moment_am2 * p, coil)
}

/// The torque (N m, world frame, about the rotor centre) of the energised coil on axis `s` on
/// the magnet in direction `p` (unit vectors, world frame): `x x F + m x B` with `x = R p`,
/// `m = m p`, `F = grad(m . B)` and B the coil's field at x.
pub fn torque_on_magnet(parts: &DipoleParts, p: &Vector3<f64>, s: &Vector3<f64>) -> Vector3<f64> {
    let (x, m, coil) = magnet_and_coil(parts, p, s);
    let (b, jac) = coil.field_and_jacobian(&x);
    let force = jac.transpose() * m;
    x.cross(&force) + m.cross(&b)
}

/// The interaction energy (J) of the magnet in direction `p` with the energised coil on axis
/// `s`: `-m . B(x)` (zero when they are infinitely far apart).
pub fn energy_of_magnet(parts: &DipoleParts, p: &Vector3<f64>, s: &Vector3<f64>) -> f64 {
    let (x, m, coil) = magnet_and_coil(parts, p, s);
    -m.dot(&coil.field(&x))
}

/// One coil and one magnet reduced to a pair well: by symmetry (a radial dipole, a coaxial
/// loop) the torque is `g(d) (p x s) / |p x s|` with `d = d(p, s)`, as the other well shapes.
/// The sign convention is `torque::Well::g`'s: `g = dU/dd`, positive for an attraction (the
/// pull -dU/dd points back to the coil). Unlike theirs, this g changes sign: beyond the
/// winding the coil's return field pushes the magnet away (g < 0).
///
/// With real parts ([`RealParts`]: a magnet of finite size, a winding) the pull is a
/// quadrature, tabulated once when the well is made ([`WellTable`]); g, the potential and the
/// stiffness are then the table's.
#[derive(Debug, Clone, PartialEq)]
pub struct DipoleWell {
    parts: DipoleParts,
    /// Grid step (rad) of the scans for the peak and the reach.
    step: f64,
    peak_d: f64,
    peak_g: f64,
    /// The real parts and their tabulated well (None: a point dipole and a thin loop).
    real: Option<Arc<(RealParts, WellTable)>>,
}

/// Cells of a real parts' table per step of the well's scans (see [`DipoleWell::real`]).
const TABLE_CELLS_PER_STEP: f64 = 1.0;

impl DipoleWell {
    /// The well of `parts`, which must validate and attract (`coil_turns_amps > 0`).
    pub fn new(parts: DipoleParts) -> Result<Self, String> {
        parts.validate()?;
        if parts.coil_turns_amps <= 0.0 {
            return Err(format!(
                "coil_turns_amps: expected > 0 for a well (an attracting coil), got {}",
                crate::text::shown(parts.coil_turns_amps)
            ));
        }
        let step = scan_step(parts.ball_radius_m, parts.coil_radius_m, parts.gap_m);
        let well = DipoleWell {
            parts,
            step,
            peak_d: 0.0,
            peak_g: 0.0,
            real: None,
        };
        well.with_peak()
    }

    /// The well of real parts: [`DipoleWell::new`]'s own for a point magnet and a thin loop
    /// (the same well, to the bit); otherwise the pull [`RealParts::torque_y`] tabulated once
    /// on [0, pi] in cells of the scans' step, set by the winding's nearest loop (its inner
    /// radius at its face).
    pub fn real(real: RealParts) -> Result<Self, String> {
        if real.is_point_and_loop() {
            return Self::new(real.loop_parts);
        }
        let parts = real.loop_parts;
        parts.validate()?;
        if parts.coil_turns_amps <= 0.0 {
            return Err(format!(
                "coil_turns_amps: expected > 0 for a well (an attracting coil), got {}",
                crate::text::shown(parts.coil_turns_amps)
            ));
        }
        let nearest_radius = real
            .winding
            .map_or(parts.coil_radius_m, |w| w.inner_radius_m);
        let step = scan_step(parts.ball_radius_m, nearest_radius, real.face_gap_m());
        // f's limits at 0 (the stiffness) and at pi, by the 4th-order difference of the odd g
        let h = 0.16 * step;
        let g = |d: f64| real.torque_y(d);
        let f0 = (8.0 * g(h) - g(2.0 * h)) / (6.0 * h);
        let f_pi = (8.0 * g(PI - h) - g(PI - 2.0 * h)) / (6.0 * h);
        let cells = (PI / (TABLE_CELLS_PER_STEP * step)).ceil() as usize;
        let table = WellTable::new(g, f0, f_pi, cells);
        let well = DipoleWell {
            parts,
            step,
            peak_d: 0.0,
            peak_g: 0.0,
            real: Some(Arc::new((real, table))),
        };
        well.with_peak()
    }

    /// The real parts the well was built from, if any (a magnet of finite size, a winding).
    pub fn real_parts(&self) -> Option<&RealParts> {
        self.real.as_deref().map(|(r, _)| r)
    }

    /// The table a real parts' well is evaluated through, if any.
    pub fn table(&self) -> Option<&WellTable> {
        self.real.as_deref().map(|(_, t)| t)
    }

    fn with_peak(mut self) -> Result<Self, String> {
        let (d, g) = self.find_peak();
        if g.is_nan() || g <= 0.0 {
            return Err(format!(
                "parts whose coil attracts a magnet somewhere, got a largest pull of {} N m \
                 (they attract nowhere): check their values",
                crate::text::shown(g)
            ));
        }
        self.peak_d = d;
        self.peak_g = g;
        Ok(self)
    }

    /// The parts the well was built from.
    pub fn parts(&self) -> &DipoleParts {
        &self.parts
    }

    /// The magnet at angle `d` from the coil's axis: `s = +Z`, `p` turned from s about +Y.
    fn magnet_at(d: f64) -> Vector3<f64> {
        Vector3::new(d.sin(), 0.0, d.cos())
    }

    /// The torque magnitude g(d) (N m) at angle `d` (rad, in [0, pi]) between magnet and coil
    /// axis, from the 3-D torque: signed, positive pulling p towards s. It is `dU/dd`.
    pub fn g(&self, d: f64) -> f64 {
        if let Some((_, table)) = self.real.as_deref() {
            return table.g(d);
        }
        // p x s = -sin(d) Y: the unit vector along it is -Y on (0, pi)
        -torque_on_magnet(&self.parts, &Self::magnet_at(d), &Vector3::z()).y
    }

    /// The potential U(d) (J): the interaction energy `-m . B` of the magnet at angle `d`
    /// (zero at infinite separation, so U(pi) is not 0); `dU/dd = g(d)`.
    pub fn potential(&self, d: f64) -> f64 {
        if let Some((_, table)) = self.real.as_deref() {
            return table.potential(d);
        }
        energy_of_magnet(&self.parts, &Self::magnet_at(d), &Vector3::z())
    }

    /// The stiffness dg/dd at d = 0 (N m / rad): 4th-order central difference of the odd g.
    pub fn stiffness(&self) -> f64 {
        if let Some((_, table)) = self.real.as_deref() {
            return table.f(0.0);
        }
        let h = 0.16 * self.step;
        (8.0 * self.g(h) - self.g(2.0 * h)) / (6.0 * h)
    }

    /// The angle of the largest g (rad) and that g (N m).
    pub fn peak(&self) -> (f64, f64) {
        (self.peak_d, self.peak_g)
    }

    fn find_peak(&self) -> (f64, f64) {
        let n = (PI / self.step).ceil() as usize;
        let h = PI / n as f64;
        let mut best = (0usize, f64::NEG_INFINITY);
        for i in 1..n {
            let g = self.g(i as f64 * h);
            if g > best.1 {
                best = (i, g);
            }
        }
        // golden-section search in the grid cell on either side of the best grid point
        let (mut lo, mut hi) = ((best.0 as f64 - 1.0) * h, (best.0 as f64 + 1.0) * h);
        let r = 0.5 * (5.0_f64.sqrt() - 1.0);
        let (mut x1, mut x2) = (hi - r * (hi - lo), lo + r * (hi - lo));
        let (mut g1, mut g2) = (self.g(x1), self.g(x2));
        while hi - lo > 1e-10 {
            if g1 < g2 {
                lo = x1;
                (x1, g1) = (x2, g2);
                x2 = lo + r * (hi - lo);
                g2 = self.g(x2);
            } else {
                hi = x2;
                (x2, g2) = (x1, g1);
                x1 = hi - r * (hi - lo);
                g1 = self.g(x1);
            }
        }
        let d = 0.5 * (lo + hi);
        let g = self.g(d);
        if g >= best.1 {
            (d, g)
        } else {
            (best.0 as f64 * h, best.1)
        }
    }

    /// The smallest angle (rad) beyond the peak where g falls to `fraction` of its peak (the
    /// "maximum distance of attraction" a planner may use, e.g. `fraction` 0.05); pi if it
    /// never does, NaN for a NaN fraction.
    pub fn reach(&self, fraction: f64) -> f64 {
        if fraction.is_nan() {
            return f64::NAN;
        }
        let target = fraction * self.peak_g;
        let mut lo = self.peak_d;
        while lo < PI {
            let hi = (lo + self.step).min(PI);
            if self.g(hi) <= target {
                return self.bisect_down_crossing(lo, hi, target);
            }
            lo = hi;
        }
        PI
    }

    /// Bisection for g = target in [lo, hi], with g(lo) > target >= g(hi).
    fn bisect_down_crossing(&self, mut lo: f64, mut hi: f64, target: f64) -> f64 {
        while hi - lo > 1e-13 {
            let mid = 0.5 * (lo + hi);
            if self.g(mid) > target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    fn vrel(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
        (a - b).norm() / b.norm()
    }

    /// A small deterministic generator (xorshift64*), uniform in [-1, 1).
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            let u = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11;
            2.0 * (u as f64 / (1u64 << 53) as f64) - 1.0
        }
        fn unit(&mut self) -> Vector3<f64> {
            loop {
                let v = Vector3::new(self.next(), self.next(), self.next());
                let n = v.norm();
                if n > 0.1 && n <= 1.0 {
                    return v / n;
                }
            }
        }
        fn rotation(&mut self) -> Rotation3<f64> {
            let axis = Unit::new_normalize(self.unit());
            Rotation3::from_axis_angle(&axis, PI * self.next())
        }
    }

    /// A coil of the prototype's size with a tilted axis and an off-origin centre.
    fn test_loop() -> CurrentLoop {
        CurrentLoop {
            centre: Vector3::new(0.03, -0.02, 0.1),
            axis: Unit::new_normalize(Vector3::new(0.3, -0.5, 0.8)),
            radius_m: 0.02,
            turns_amps: 1000.0,
            gain: 1.5,
        }
    }

    /// The point at distance r from the loop's centre, at polar angle t from its axis.
    fn point_at(lp: &CurrentLoop, r: f64, t: f64) -> Vector3<f64> {
        let n = lp.axis.into_inner();
        let e = perpendicular(&n);
        lp.centre + r * (t.cos() * n + t.sin() * e)
    }

    /// 4th-order central-difference Cartesian Jacobian of a vector field (independent of the
    /// module's own Jacobian).
    fn cartesian_jacobian(
        f: impl Fn(&Vector3<f64>) -> Vector3<f64>,
        x: &Vector3<f64>,
        h: f64,
    ) -> Matrix3<f64> {
        let mut jac = Matrix3::zeros();
        for j in 0..3 {
            let mut e = Vector3::zeros();
            e[j] = h;
            let col = (8.0 * (f(&(x + e)) - f(&(x - e))) - (f(&(x + 2.0 * e)) - f(&(x - 2.0 * e))))
                / (12.0 * h);
            jac.set_column(j, &col);
        }
        jac
    }

    #[test]
    fn elliptic_integrals_match_known_values() {
        let (k0, e0) = elliptic_ke(0.0);
        assert_eq!(k0, FRAC_PI_2);
        assert_eq!(e0, FRAC_PI_2);
        // k = 1/sqrt(2), i.e. parameter m = 1/2
        let (k, e) = elliptic_ke(0.5);
        // (the references are rounded to 16 digits: 2 ulp)
        assert!(rel(k, 1.854_074_677_301_372) < 5e-16, "K = {k:.17}");
        assert!(rel(e, 1.350_643_881_047_675) < 5e-16, "E = {e:.17}");
        // m = 0.9 (k = 0.948683...): K = 2.578092113348173, E = 1.104774732704073
        let (k, e) = elliptic_ke(0.9);
        assert!(rel(k, 2.578_092_113_348_173) < 1e-15, "K(0.9) = {k:.17}");
        assert!(rel(e, 1.104_774_732_704_073) < 1e-15, "E(0.9) = {e:.17}");
        // Legendre's relation E K' + E' K - K K' = pi/2 over the whole range
        for &m in &[1e-12, 1e-6, 0.01, 0.1, 0.3, 0.5, 0.77, 0.99, 0.999_999] {
            let (k, e) = elliptic_ke(m);
            let (kc, ec) = elliptic_ke(1.0 - m);
            let legendre = e * kc + ec * k - k * kc;
            assert!(rel(legendre, FRAC_PI_2) < 1e-14, "m = {m}: {legendre}");
        }
        assert_eq!(elliptic_ke(1.0), (f64::INFINITY, 1.0));
        assert!(elliptic_ke(f64::NAN).0.is_nan() && elliptic_ke(1.5).1.is_nan());
    }

    #[test]
    fn h_series_and_closed_form_agree() {
        let h = |m: f64| {
            let (k, e) = elliptic_ke(m);
            h_and_slope(m, k, e)
        };
        assert!(rel(h(0.0).0, 3.0 * PI / 16.0) < 1e-15 && h(0.0).1 == 0.0);
        // the series against the closed form where the closed form still has ~13 digits (the
        // slope ~11)
        for &m in &[0.12, 0.2, H_SERIES_BELOW * (1.0 - 1e-12)] {
            let (k, e) = elliptic_ke(m);
            let closed = ((2.0 - m) * e - 2.0 * (1.0 - m) * k) / (m * m);
            let closed_slope = 1.5 * (k - e) / m - 2.0 * closed;
            assert!(rel(h(m).0, closed) < 1e-13, "m = {m}");
            // (the closed-form slope itself cancels ~1e-11 away at m = 0.12)
            assert!(rel(h(m).1, closed_slope) < 1e-10, "m = {m}");
        }
        // continuous across the switch, and m H' is m times the derivative of H
        let (below, above) = (h(H_SERIES_BELOW * (1.0 - 1e-15)), h(H_SERIES_BELOW));
        assert!(rel(below.0, above.0) < 1e-14 && rel(below.1, above.1) < 1e-13);
        for &m in &[0.01, 0.1, 0.29, 0.31, 0.5, 0.9] {
            let dm = 1e-4 * m;
            let fd = (8.0 * (h(m + dm).0 - h(m - dm).0) - (h(m + 2.0 * dm).0 - h(m - 2.0 * dm).0))
                / (12.0 * dm);
            assert!(
                rel(h(m).1, m * fd) < 1e-8,
                "m = {m}: {} vs {}",
                h(m).1,
                m * fd
            );
        }
    }

    #[test]
    fn axial_derivatives_match_differences() {
        let (a, ni) = (0.02, 1500.0);
        for &(rho, z) in &[
            (0.0, 0.013),
            (1e-7, -0.02),
            (0.002, 0.005),
            (0.01, 0.0),
            (0.018, 0.003),
            (0.024, -0.004),
            (0.05, 0.03),
            (0.3, -0.4),
        ] {
            let f = loop_field_cylindrical_dz(a, ni, rho, z);
            let alpha = ((a - rho).powi(2) + z * z).sqrt();
            let dz = 1e-3 * alpha;
            let at = |zz: f64| loop_field_cylindrical(a, ni, rho, zz);
            let (p1, m1, p2, m2) = (at(z + dz), at(z - dz), at(z + 2.0 * dz), at(z - 2.0 * dz));
            let dq = (8.0 * (p1.0 - m1.0) - (p2.0 - m2.0)) / (12.0 * dz);
            let dbz = (8.0 * (p1.1 - m1.1) - (p2.1 - m2.1)) / (12.0 * dz);
            // scales: |dq/dz| ~ |q| / alpha at most, |dBz/dz| ~ |B| / alpha
            let q_scale = f.q.abs().max(f.bz.abs() / alpha) / alpha;
            let b_scale = f.q.abs().max(f.bz.abs() / alpha) * alpha.max(rho) / alpha;
            assert!(
                (f.dq_dz - dq).abs() < 1e-9 * q_scale,
                "({rho}, {z}): {} vs {dq}",
                f.dq_dz
            );
            assert!(
                (f.dbz_dz - dbz).abs() < 1e-9 * b_scale,
                "({rho}, {z}): {}",
                f.dbz_dz
            );
        }
    }

    #[test]
    fn exact_field_matches_biot_savart() {
        let lp = test_loop();
        let n = lp.axis.into_inner();
        let (e, f) = (perpendicular(&n), n.cross(&perpendicular(&n)));
        let ni = lp.gain * lp.turns_amps;
        // the trapezoidal rule on the periodic Biot-Savart integral converges geometrically
        let segments = 20_000;
        for x in off_axis_points(&lp) {
            let mut b = Vector3::zeros();
            for i in 0..segments {
                let phi = 2.0 * PI * i as f64 / segments as f64;
                let (c, s) = (phi.cos(), phi.sin());
                let wire = lp.centre + lp.radius_m * (c * e + s * f);
                let dl = lp.radius_m * (-s * e + c * f) * (2.0 * PI / segments as f64);
                let r = x - wire;
                b += dl.cross(&r) / r.norm().powi(3);
            }
            b *= MU0_OVER_4PI * ni;
            assert!(
                vrel(&lp.field_exact(&x), &b) < 1e-12,
                "{x}: {}",
                vrel(&lp.field_exact(&x), &b)
            );
        }
    }

    #[test]
    fn loop_on_axis_field_matches_closed_form() {
        let lp = test_loop();
        let (a, ni) = (lp.radius_m, lp.gain * lp.turns_amps);
        let n = lp.axis.into_inner();
        for &z in &[-0.3, -0.05, -0.01, 0.0, 1e-9, 0.004, 0.02, 0.1, 0.5] {
            let x = lp.centre + z * n;
            let b = lp.field(&x);
            let expected = MU0 * ni * a * a / (2.0 * (a * a + z * z).powf(1.5));
            assert!(rel(b.dot(&n), expected) < 1e-12, "z = {z}: {b}");
            assert!(
                (b - b.dot(&n) * n).norm() <= 1e-12 * expected,
                "z = {z}: {b}"
            );
        }
        // the centre: mu0 N I / (2 a)
        assert!(rel(lp.field(&lp.centre).dot(&n), MU0 * ni / (2.0 * a)) < 1e-14);
    }

    #[test]
    fn loop_field_near_axis_is_finite_and_smooth() {
        let lp = test_loop();
        let (a, ni) = (lp.radius_m, lp.gain * lp.turns_amps);
        let z = 0.013;
        // near-axis expansion: B_rho = -(rho/2) dB0/dz + O(rho^3)
        let db0 = -1.5 * MU0 * ni * a * a * z / (a * a + z * z).powf(2.5);
        for &rho in &[0.0, 1e-300, 1e-12, 1e-8, 1e-6 * a] {
            let (q, bz) = loop_field_cylindrical(a, ni, rho, z);
            assert!(q.is_finite() && bz.is_finite(), "rho = {rho}");
            assert!(rel(q, -0.5 * db0) < 1e-10, "rho = {rho}: {q}");
        }
        let (q, bz) = loop_field_cylindrical(a, ni, 0.0, 0.0);
        assert!(q == 0.0 && rel(bz, MU0 * ni / (2.0 * a)) < 1e-15);
        let (b, jac) = lp.field_and_jacobian(&lp.centre);
        assert!(b.iter().chain(jac.iter()).all(|v| v.is_finite()));
    }

    #[test]
    fn exact_field_far_away_matches_the_dipole_with_the_known_correction() {
        let lp = test_loop();
        for &t in &[0.0, 0.3, 0.9553, PI / 2.0, 2.2, PI] {
            let x = point_at(&lp, 1000.0 * lp.radius_m, t);
            let err = vrel(&lp.field_far(&x), &lp.field_exact(&x));
            // the leading correction is at most (3/2) (a/r)^2 = 1.5e-6, reached on the axis
            assert!(err < 1.5e-6 * 1.001, "t = {t}: {err}");
            if t == 0.0 || t == PI {
                assert!(rel(err, 1.5e-6) < 1e-3, "on the axis: {err}");
            }
        }
    }

    #[test]
    fn far_field_error_is_below_1e4_at_and_beyond_the_switch() {
        let lp = test_loop();
        let rs = lp.switch_distance();
        let mut worst: f64 = 0.0;
        for &f in &[1.0, 1.01, 1.5, 3.0, 10.0] {
            for i in 0..=36 {
                let t = PI * i as f64 / 36.0;
                let x = point_at(&lp, f * rs, t);
                let err = vrel(&lp.field_far(&x), &lp.field_exact(&x));
                assert!(err < 1e-4, "r = {f} r_switch, t = {t}: {err}");
                worst = worst.max(err);
            }
        }
        // the bound is nearly reached (the test would see a worse switch)
        assert!(worst > 8.5e-5, "{worst}");
    }

    #[test]
    fn field_is_continuous_across_the_switch() {
        let lp = test_loop();
        let rs = lp.switch_distance();
        for &t in &[0.0, 0.7, PI / 2.0, 2.5] {
            let inside = point_at(&lp, rs * (1.0 - 1e-12), t);
            let outside = point_at(&lp, rs * (1.0 + 1e-12), t);
            assert!(!lp.uses_far_field(&inside) && lp.uses_far_field(&outside));
            let (bi, bo) = (lp.field(&inside), lp.field(&outside));
            assert!(vrel(&bo, &bi) < 1e-4, "t = {t}");
            let (_, ji) = lp.field_and_jacobian(&inside);
            let (_, jo) = lp.field_and_jacobian(&outside);
            assert!((jo - ji).norm() < 1e-3 * ji.norm(), "t = {t}");
        }
    }

    /// Off-axis points inside, at and outside the loop's radius, some near the wire.
    fn off_axis_points(lp: &CurrentLoop) -> Vec<Vector3<f64>> {
        let a = lp.radius_m;
        let n = lp.axis.into_inner();
        let e = perpendicular(&n);
        let f = n.cross(&e);
        [
            (0.3, 0.2),
            (0.9, 0.05),
            (1.0, 0.1),
            (1.2, -0.02),
            (2.0, 1.0),
            (0.5, -1.5),
            (4.0, 3.0),
            (20.0, -30.0),
        ]
        .iter()
        .enumerate()
        .map(|(i, &(rho, z))| {
            let phi = 0.7 * i as f64;
            lp.centre + a * (rho * (phi.cos() * e + phi.sin() * f) + z * n)
        })
        .collect()
    }

    #[test]
    fn exact_field_is_divergence_and_curl_free() {
        let lp = test_loop();
        for x in off_axis_points(&lp) {
            let c = lp.coordinates(&x);
            let alpha = ((lp.radius_m - c.rho).powi(2) + c.z * c.z).sqrt();
            let jac = cartesian_jacobian(|y| lp.field_exact(y), &x, 2e-3 * alpha);
            let div = jac.trace();
            let curl = Vector3::new(
                jac[(2, 1)] - jac[(1, 2)],
                jac[(0, 2)] - jac[(2, 0)],
                jac[(1, 0)] - jac[(0, 1)],
            );
            assert!(div.abs() < 1e-9 * jac.norm(), "{x}: div {div}");
            assert!(curl.norm() < 1e-9 * jac.norm(), "{x}: curl {curl}");
        }
    }

    #[test]
    fn jacobian_matches_closed_form_on_the_axis() {
        let lp = test_loop();
        let (a, ni) = (lp.radius_m, lp.gain * lp.turns_amps);
        let n = lp.axis.into_inner();
        let e = perpendicular(&n);
        for &z in &[-0.04, -0.01, 0.0, 0.005, 0.01, 0.03, 0.2] {
            let (_, jac) = lp.field_and_jacobian(&(lp.centre + z * n));
            let dbz = -1.5 * MU0 * ni * a * a * z / (a * a + z * z).powf(2.5);
            // a B0/dz^2 sets the scale where dB0/dz = 0 (the centre)
            let scale = (1.5 * MU0 * ni * a * a / (a * a + z * z).powf(2.5) * a).max(dbz.abs());
            let expected =
                dbz * (n * n.transpose() - 0.5 * (Matrix3::identity() - n * n.transpose()));
            assert!((jac - expected).norm() < 1e-13 * scale, "z = {z}");
            assert!(((jac * e).dot(&e) + 0.5 * dbz).abs() < 1e-13 * scale);
        }
    }

    #[test]
    fn jacobian_matches_cartesian_differences_and_line_integrals() {
        let lp = test_loop();
        let moment = Vector3::new(0.4, 1.1, -0.7);
        for x in off_axis_points(&lp) {
            let c = lp.coordinates(&x);
            let alpha = ((lp.radius_m - c.rho).powi(2) + c.z * c.z).sqrt();
            let (_, jac) = lp.field_and_jacobian_exact(&x);
            let reference = cartesian_jacobian(|y| lp.field_exact(y), &x, 2e-3 * alpha);
            assert!((jac - reference).norm() < 1e-9 * jac.norm(), "{x}");
            // int_0^1 grad(m . B)(x + t delta) . delta dt = m . B(x + delta) - m . B(x),
            // Simpson's rule on 200 intervals (error ~1e-12 relative)
            let delta = 0.3 * alpha * Vector3::new(0.6, -0.48, 0.64);
            let n = 200;
            let mut integral = 0.0;
            for i in 0..=n {
                let w = if i == 0 || i == n {
                    1.0
                } else if i % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                let y = x + delta * (i as f64 / n as f64);
                integral += w * lp.grad_m_dot_b(&y, &moment).dot(&delta);
            }
            integral /= 3.0 * n as f64;
            let exact = moment.dot(&(lp.field_exact(&(x + delta)) - lp.field_exact(&x)));
            let scale = moment.norm() * lp.field_exact(&x).norm() * 0.3;
            assert!(
                (integral - exact).abs() < 1e-9 * scale,
                "{x}: {integral} vs {exact}"
            );
        }
    }

    #[test]
    fn dipole_jacobian_matches_differences_of_the_field() {
        let m = Vector3::new(0.3, -1.2, 0.5);
        for r in [
            Vector3::new(0.1, 0.02, -0.03),
            Vector3::new(-0.01, 0.0, 0.02),
        ] {
            let jac = dipole_field_jacobian(&m, &r);
            let fd = cartesian_jacobian(|y| dipole_field(&m, y), &r, 1e-3 * r.norm());
            assert!((jac - fd).norm() < 1e-10 * jac.norm());
            assert!(jac.trace().abs() < 1e-14 * jac.norm());
            assert!((jac - jac.transpose()).norm() < 1e-14 * jac.norm());
        }
    }

    #[test]
    fn dipole_force_and_torque_match_closed_forms() {
        let k = MU0 / (4.0 * PI);
        let (m1, m2, r) = (1.3, 0.7, 0.05);
        let (x1, x2) = (
            Vector3::new(0.01, 0.02, 0.03),
            Vector3::new(0.01, 0.02, 0.03 + r),
        );
        // coaxial, parallel: attraction -6 k m1 m2 / r^4 along the line
        let f = dipole_force(&(m1 * Vector3::z()), &x1, &(m2 * Vector3::z()), &x2);
        assert!(vrel(&f, &(-6.0 * k * m1 * m2 / r.powi(4) * Vector3::z())) < 1e-14);
        // side by side, parallel: repulsion 3 k m1 m2 / r^4
        let f = dipole_force(&(m1 * Vector3::x()), &x1, &(m2 * Vector3::x()), &x2);
        assert!(vrel(&f, &(3.0 * k * m1 * m2 / r.powi(4) * Vector3::z())) < 1e-14);
        // m2 across the field of m1 on the equator: B1 = -k m1 / r^3 z, tau = k m1 m2 / r^3 y
        let x2 = x1 + r * Vector3::x();
        let tau = dipole_torque(&(m1 * Vector3::z()), &x1, &(m2 * Vector3::x()), &x2);
        assert!(vrel(&tau, &(k * m1 * m2 / r.powi(3) * Vector3::y())) < 1e-14);
        // a generic pair: the closed-form force is grad(m2 . B1), by the Jacobian and by
        // differences of the energy
        let mut rng = Rng(7);
        for _ in 0..10 {
            let (a, b) = (rng.unit() * 1.1, rng.unit() * 0.6);
            let (y1, y2) = (
                rng.unit() * 0.02,
                rng.unit() * 0.05 + Vector3::new(0.0, 0.0, 0.08),
            );
            let f = dipole_force(&a, &y1, &b, &y2);
            let via_jacobian = dipole_field_jacobian(&a, &(y2 - y1)).transpose() * b;
            assert!(vrel(&f, &via_jacobian) < 1e-13);
            let h = 1e-4 * (y2 - y1).norm();
            let energy = |y: Vector3<f64>| b.dot(&dipole_field(&a, &(y - y1)));
            let grad = Vector3::from_fn(|i, _| {
                let mut e = Vector3::zeros();
                e[i] = h;
                (8.0 * (energy(y2 + e) - energy(y2 - e))
                    - (energy(y2 + 2.0 * e) - energy(y2 - 2.0 * e)))
                    / (12.0 * h)
            });
            assert!(vrel(&f, &grad) < 1e-9);
        }
    }

    #[test]
    fn dipole_pair_obeys_newton_and_angular_momentum_balance() {
        let mut rng = Rng(11);
        for _ in 0..20 {
            let (m1, m2) = (rng.unit() * 1.9, rng.unit() * 0.8);
            let (x1, x2) = (
                rng.unit() * 0.15,
                rng.unit() * 0.15 + Vector3::new(0.1, 0.0, 0.0),
            );
            let f21 = dipole_force(&m1, &x1, &m2, &x2); // on 2
            let f12 = dipole_force(&m2, &x2, &m1, &x1); // on 1
            let scale = f21.norm();
            assert!((f12 + f21).norm() < 1e-14 * scale);
            let t21 = dipole_torque(&m1, &x1, &m2, &x2);
            let t12 = dipole_torque(&m2, &x2, &m1, &x1);
            let total = x1.cross(&f12) + t12 + x2.cross(&f21) + t21;
            let tscale = t21.norm() + t12.norm() + (x1.norm() + x2.norm()) * scale;
            assert!(total.norm() < 1e-13 * tscale, "{total}");
        }
    }

    #[test]
    fn torque_rotates_with_the_frame() {
        let parts = DipoleParts::prototype();
        let mut rng = Rng(3);
        for _ in 0..20 {
            let s = rng.unit();
            let p =
                Rotation3::from_axis_angle(&Unit::new_normalize(rng.unit()), 0.8 * rng.next()) * s;
            let rot = rng.rotation();
            let tau = torque_on_magnet(&parts, &p, &s);
            let turned = torque_on_magnet(&parts, &(rot * p), &(rot * s));
            let err = (turned - rot * tau).norm() / tau.norm();
            assert!(err < 1e-12, "{tau}: {err}");
        }
    }

    #[test]
    fn torque_lies_along_p_cross_s_and_equals_g() {
        let parts = DipoleParts {
            core_gain: 1.7,
            ..DipoleParts::prototype()
        };
        let well = DipoleWell::new(parts).expect("valid parts");
        let mut rng = Rng(5);
        for &d in &[1e-4, 0.01, 0.1, 0.3, 0.7, 1.5, 2.5, 3.1] {
            let s = rng.unit();
            let axis = Unit::new_normalize(s.cross(&rng.unit()));
            let p = Rotation3::from_axis_angle(&axis, d) * s;
            let tau = torque_on_magnet(&parts, &p, &s);
            let u = p.cross(&s).normalize();
            let along = tau.dot(&u);
            assert!((tau - along * u).norm() < 1e-12 * tau.norm(), "d = {d}");
            let d_meas = p.cross(&s).norm().atan2(p.dot(&s));
            assert!(
                (along - well.g(d_meas)).abs() < 1e-12 * well.peak().1,
                "d = {d}"
            );
        }
        // aligned: no torque, and the force pulls the magnet towards the coil (attraction)
        let (x, m, coil) = magnet_and_coil(&parts, &Vector3::z(), &Vector3::z());
        assert!(coil.grad_m_dot_b(&x, &m).z > 0.0);
        assert!(well.g(0.0).abs() < 1e-15 * well.peak().1);
    }

    #[test]
    fn potential_derivative_is_g() {
        let well = DipoleWell::new(DipoleParts::prototype()).expect("valid parts");
        let peak = well.peak().1;
        for &d in &[0.02, 0.08, 0.15, 0.4, 0.9, 1.6, 2.4, 3.0] {
            let h = 1e-4;
            let du = (8.0 * (well.potential(d + h) - well.potential(d - h))
                - (well.potential(d + 2.0 * h) - well.potential(d - 2.0 * h)))
                / (12.0 * h);
            assert!(
                (du - well.g(d)).abs() < 1e-9 * peak,
                "d = {d}: {du} vs {}",
                well.g(d)
            );
        }
        // bound at the coil: negative energy there, and it rises away from it
        assert!(well.potential(0.0) < 0.0 && well.potential(0.0) < well.potential(0.3));
    }

    #[test]
    fn stiffness_peak_and_reach_are_consistent() {
        let well = DipoleWell::new(DipoleParts::prototype()).expect("valid parts");
        let k = well.stiffness();
        let d = 1e-5;
        assert!(rel(k, well.g(d) / d) < 1e-7, "{k} vs {}", well.g(d) / d);
        let (dp, gp) = well.peak();
        for i in 0..=4000 {
            let x = PI * i as f64 / 4000.0;
            assert!(well.g(x) <= gp * (1.0 + 1e-12), "d = {x}");
        }
        assert!(well.g(dp * 0.99) < gp && well.g(dp * 1.01) < gp);
        for &f in &[0.5, 0.2, 0.05] {
            let r = well.reach(f);
            assert!(r > dp && rel(well.g(r), f * gp) < 1e-9, "fraction {f}");
            let h = (r - dp) / 200.0;
            assert!((1..200).all(|i| well.g(dp + i as f64 * h) > f * gp));
        }
        assert!(well.reach(0.05) > well.reach(0.2));
        assert!(well.reach(f64::NAN).is_nan());
    }

    #[test]
    fn negative_current_repels() {
        let parts = DipoleParts::prototype();
        let reversed = DipoleParts {
            coil_turns_amps: -parts.coil_turns_amps,
            ..parts
        };
        let (p, s) = (Vector3::new(0.1, 0.0, 1.0).normalize(), Vector3::z());
        let tau = torque_on_magnet(&parts, &p, &s);
        assert!(vrel(&torque_on_magnet(&reversed, &p, &s), &(-tau)) < 1e-14);
        assert!(tau.dot(&p.cross(&s)) > 0.0);
        assert!(DipoleWell::new(reversed).is_err());
    }

    #[test]
    fn moment_from_remanence_of_the_prototype_magnet() {
        let v = disc_volume(0.75 * 0.0254, 0.25 * 0.0254);
        assert!(rel(v, PI * 0.009525 * 0.009525 * 0.00635) < 1e-15);
        let m = magnet_moment_from_remanence(1.3, v);
        assert!(rel(m, 1.3 * v / (4e-7 * PI)) < 1e-15 && (1.85..1.9).contains(&m));
        let parts = DipoleParts::from_remanence(0.1524, 1.3, v, 1000.0, 0.02, 0.01, 1.0);
        assert_eq!(parts, Ok(DipoleParts::prototype()));
        let bad = DipoleParts::from_remanence(0.1524, -1.3, v, 1000.0, 0.02, 0.01, 1.0);
        assert!(bad.is_err_and(|e| e.starts_with("br_t:")));
    }

    #[test]
    fn validate_names_the_offending_field() {
        let ok = DipoleParts::prototype();
        assert_eq!(ok.validate(), Ok(()));
        assert_eq!(DipoleParts { gap_m: 0.0, ..ok }.validate(), Ok(()));
        type Spoil = fn(&mut DipoleParts);
        let cases: [(&str, Spoil); 10] = [
            ("gap_m:", |p| p.gap_m = -0.001),
            ("gap_m:", |p| p.gap_m = f64::INFINITY),
            ("ball_radius_m:", |p| p.ball_radius_m = 0.0),
            ("coil_radius_m:", |p| p.coil_radius_m = 0.0),
            ("coil_radius_m:", |p| p.coil_radius_m = f64::NAN),
            ("magnet_moment_am2:", |p| p.magnet_moment_am2 = f64::NAN),
            ("magnet_moment_am2:", |p| p.magnet_moment_am2 = -1.0),
            ("coil_turns_amps:", |p| p.coil_turns_amps = f64::NAN),
            ("core_gain:", |p| p.core_gain = 0.9),
            ("core_gain:", |p| p.core_gain = f64::NAN),
        ];
        for (field, spoil) in cases {
            let mut parts = ok;
            spoil(&mut parts);
            let err = parts.validate().expect_err(field);
            assert!(err.starts_with(field) && err.contains("expected"), "{err}");
        }
        assert!(DipoleWell::new(DipoleParts { gap_m: -1.0, ..ok }).is_err());
    }

    #[test]
    fn prototype_well_numbers() {
        // the estimated prototype's well (a regression check of the numbers reported with the
        // module): a ring-shaped well, strongest where the magnet passes under the winding
        let well = DipoleWell::new(DipoleParts::prototype()).expect("valid parts");
        let (dp, gp) = well.peak();
        assert!(
            rel(well.stiffness(), 0.81182) < 1e-4,
            "{}",
            well.stiffness()
        );
        assert!(
            rel(gp, 0.54935) < 1e-4 && rel(dp.to_degrees(), 6.791) < 1e-3,
            "{gp} {dp}"
        );
        assert!(rel(well.reach(0.5).to_degrees(), 8.918) < 1e-3);
        assert!(rel(well.reach(0.05).to_degrees(), 11.219) < 1e-3);
        // beyond the winding the field returns: g < 0 (a push away) from 12.006 degrees on,
        // down to -0.0207 N m, and the energy of the farthest magnet is slightly positive
        let zero = well.reach(0.0);
        assert!(
            rel(zero.to_degrees(), 12.006) < 1e-3,
            "{}",
            zero.to_degrees()
        );
        assert!((1..=360).all(|i| well.g(zero + (PI - zero) * i as f64 / 361.0) < 0.0));
        assert!(rel(well.g(15f64.to_radians()), -0.02032) < 1e-3);
        assert!(well.potential(0.0) < -0.042 && well.potential(PI) > 0.0);
    }
}
