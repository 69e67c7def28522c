//! Geometry on the unit sphere and of rotations: angular distance, the paper's ROT[n, theta],
//! numerically safe angle/axis extraction, and the small typed wrappers (degrees, radians, unit
//! vectors, coil and magnet indices) that keep units and indices from being confused.

use nalgebra::{Matrix3, Quaternion, Rotation3, Unit, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// A unit vector in R^3 (a point on the unit sphere).
pub type UnitVec = Unit<Vector3<f64>>;
/// An orientation, body to world, as a unit quaternion (q1, q2, q3, q4) = (vector, scalar).
pub type Orientation = UnitQuaternion<f64>;

/// An angle in degrees. Only converted to radians explicitly.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Serialize, Deserialize, Default)]
#[serde(transparent)]
pub struct Degrees(pub f64);

/// An angle in radians.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Serialize, Deserialize, Default)]
#[serde(transparent)]
pub struct Radians(pub f64);

impl Degrees {
    /// The same angle in radians.
    pub fn to_radians(self) -> Radians {
        Radians(self.0.to_radians())
    }
}

impl Radians {
    /// The same angle in degrees.
    pub fn to_degrees(self) -> Degrees {
        Degrees(self.0.to_degrees())
    }
}

impl From<Degrees> for Radians {
    fn from(d: Degrees) -> Self {
        d.to_radians()
    }
}

impl From<Radians> for Degrees {
    fn from(r: Radians) -> Self {
        r.to_degrees()
    }
}

/// Index of a stator coil (0-based).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct CoilId(pub usize);

/// Index of a rotor magnet (0-based).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct MagnetId(pub usize);

impl fmt::Display for CoilId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

impl fmt::Display for MagnetId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// A pair: stator coil `coil` attracting rotor magnet `magnet`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct Pair {
    /// The energised stator coil.
    pub coil: CoilId,
    /// The rotor magnet it pulls.
    pub magnet: MagnetId,
}

impl Pair {
    /// Coil `coil` pulling magnet `magnet`.
    pub fn new(coil: usize, magnet: usize) -> Self {
        Pair {
            coil: CoilId(coil),
            magnet: MagnetId(magnet),
        }
    }
}

/// The text form of a set of pairs in files: `coil:magnet;coil:magnet`.
pub fn pairs_text(pairs: &[Pair]) -> String {
    pairs
        .iter()
        .map(|p| p.to_string())
        .collect::<Vec<_>>()
        .join(";")
}

impl fmt::Display for Pair {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.coil, self.magnet)
    }
}

/// One pair written `coil:magnet` (0-based), the form `Display` writes.
impl FromStr for Pair {
    type Err = ();
    fn from_str(s: &str) -> std::result::Result<Pair, ()> {
        let (c, m) = s.split_once(':').ok_or(())?;
        match (c.trim().parse::<usize>(), m.trim().parse::<usize>()) {
            (Ok(c), Ok(m)) => Ok(Pair::new(c, m)),
            _ => Err(()),
        }
    }
}

/// Angular distance on the sphere, d(a, b) = acos(clamp(a . b, -1, 1)), in [0, pi].
///
/// Computed with atan2 of the cross and dot products, which is accurate also near 0 and pi.
pub fn angular_distance(a: &UnitVec, b: &UnitVec) -> Radians {
    Radians(a.cross(b).norm().atan2(a.dot(b)))
}

/// A cheap first test of "is the angle between two directions more than `limit`", before
/// [`angular_distance`]'s atan2: a pair whose dot product is below cos(limit + 1e-9) times
/// their lengths is further apart than `limit` by more than either computation's rounding, so
/// it is one that [`angular_distance`] puts beyond `limit` too; the others are decided by the
/// angle itself.
#[derive(Debug, Clone, Copy)]
pub struct SurelyBeyond {
    cos: f64,
}

impl SurelyBeyond {
    /// The test for angles of `limit`.
    pub fn new(limit: Radians) -> Self {
        SurelyBeyond {
            cos: (limit.0 + 1e-9).min(std::f64::consts::PI).cos(),
        }
    }

    /// Whether `a` and `b` (any lengths) are surely more than the limit apart.
    #[inline]
    pub fn apart(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> bool {
        a.dot(b) < self.cos * (a.norm() * b.norm())
    }
}

/// The paper's ROT[n, theta] = exp(theta N) as a rotation matrix.
pub fn rot(n: &UnitVec, theta: Radians) -> Rotation3<f64> {
    Rotation3::from_axis_angle(n, theta.0)
}

/// ROT[n, theta] as a unit quaternion.
pub fn rot_q(n: &UnitVec, theta: Radians) -> Orientation {
    UnitQuaternion::from_axis_angle(n, theta.0)
}

/// Angle theta(R) in [0, pi] of a rotation, computed from its quaternion (safe near 0 and pi).
pub fn rotation_angle(q: &Orientation) -> Radians {
    let v = q.imag().norm();
    let w = q.w.abs();
    Radians(2.0 * v.atan2(w))
}

/// Axis n(R) of a rotation (the direction of its positive rotation), or `None` for the identity
/// (angle below 1e-12 rad), where the axis is undefined.
pub fn rotation_axis(q: &Orientation) -> Option<UnitVec> {
    let v = q.imag();
    let n = v.norm();
    if n < 1e-12 * 0.5 {
        return None;
    }
    let sign = if q.w < 0.0 { -1.0 } else { 1.0 };
    Some(Unit::new_unchecked(v * (sign / n)))
}

/// The paper's theta(R) = acos((tr R - 1)/2), evaluated safely: the matrix is converted to a
/// quaternion first, so there is no division by ~0 near theta = 0 or pi.
pub fn matrix_angle(r: &Matrix3<f64>) -> Radians {
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*r));
    rotation_angle(&q)
}

/// Rotation angle of `q` about the signed axis `n`: the angle of the rotation, with the sign of
/// the projection of its axis on `n`.
pub fn signed_angle_about(q: &Orientation, n: &UnitVec) -> Radians {
    match rotation_axis(q) {
        None => Radians(0.0),
        Some(a) => {
            let th = rotation_angle(q).0;
            if a.dot(n) >= 0.0 {
                Radians(th)
            } else {
                Radians(-th)
            }
        }
    }
}

/// Axis error of a rotation relative to the desired axis `n`: the angle between n(R) (the
/// direction of its positive rotation, angle in [0, pi]) and n. A rotation that turns backwards
/// about n has n(R) = -n and an error near pi: callers that follow the turn's sign along a plan
/// (the cumulative angle) measure such a turn against -n themselves. The identity has no axis
/// and an error of 0.
pub fn axis_error(q: &Orientation, n: &UnitVec) -> Radians {
    match rotation_axis(q) {
        None => Radians(0.0),
        Some(a) => angular_distance(&a, n),
    }
}

/// A unit vector from raw components, or `None` for a zero, non-finite vector.
pub fn unit(v: Vector3<f64>) -> Option<UnitVec> {
    let n = v.norm();
    if !n.is_finite() || n < 1e-12 || v.iter().any(|c| !c.is_finite()) {
        None
    } else {
        Some(Unit::new_normalize(v))
    }
}

/// Quaternion from file components (qx, qy, qz, qw), normalised; `None` if zero or not finite.
pub fn orientation_from_xyzw(x: f64, y: f64, z: f64, w: f64) -> Option<Orientation> {
    let q = Quaternion::new(w, x, y, z);
    let n = q.norm();
    if !n.is_finite() || n < 1e-12 || [x, y, z, w].iter().any(|c| !c.is_finite()) {
        None
    } else {
        Some(UnitQuaternion::from_quaternion(q))
    }
}

/// File components (qx, qy, qz, qw) of an orientation, with qw >= 0 (the same rotation).
pub fn xyzw(q: &Orientation) -> [f64; 4] {
    let s = if q.w < 0.0 { -1.0 } else { 1.0 };
    [s * q.i, s * q.j, s * q.k, s * q.w]
}

/// The angle (rotation angle, like `Orientation::angle_to`) from `q` to the nearest point of
/// the geodesic (the slerp) from `a` to `b` ([`nearest_on_geodesic`]): 0 on the path, the
/// distance to the nearer end beyond it. `q` and `-q` (the same orientation) give the same
/// answer, and so do `a`, `b` and their negatives; for `a` == `b` it is the distance from `q`
/// to `a`.
pub fn distance_to_geodesic(q: &Orientation, a: &Orientation, b: &Orientation) -> Radians {
    let qv = q.quaternion().coords;
    let nearest = nearest_coords(q, a, b);
    // the angle between q and the nearest point in R^4, doubled (a rotation angle), from
    // atan2 so that it is accurate near 0
    let m = qv.dot(&nearest);
    let off = (qv - nearest * m).norm();
    Radians(2.0 * off.atan2(m.abs()))
}

/// The point of the geodesic (the slerp) from `a` to `b` nearest to `q` (`a` for `a` == `b`).
///
/// With `b` signed so that <a, b> >= 0 and `c` the unit component of `b` orthogonal to `a`
/// (in R^4), the path is p(phi) = cos(phi) a + sin(phi) c for phi in [0, theta], theta the
/// angle between `a` and `b`; the nearest point maximises |<q, p(phi)>| = |A cos(phi) +
/// B sin(phi)| (A = <q, a>, B = <q, c>), found among the ends and the stationary points
/// atan2(B, A) and atan2(-B, -A) inside [0, theta].
pub fn nearest_on_geodesic(q: &Orientation, a: &Orientation, b: &Orientation) -> Orientation {
    Orientation::new_normalize(Quaternion::from(nearest_coords(q, a, b)))
}

/// [`nearest_on_geodesic`] as the quaternion's coordinates (unit to rounding).
fn nearest_coords(q: &Orientation, a: &Orientation, b: &Orientation) -> nalgebra::Vector4<f64> {
    let (qv, av) = (q.quaternion().coords, a.quaternion().coords);
    let mut bv = b.quaternion().coords;
    if av.dot(&bv) < 0.0 {
        bv = -bv;
    }
    let along = av.dot(&bv);
    let ortho = bv - av * along;
    match ortho.norm() {
        // a == b (to rounding): the path is a point
        n if n < 1e-12 => av,
        n => {
            let c = ortho / n;
            let theta = n.atan2(along);
            let (ca, cb) = (qv.dot(&av), qv.dot(&c));
            let at = |phi: f64| av * phi.cos() + c * phi.sin();
            let best = [0.0, theta, cb.atan2(ca), (-cb).atan2(-ca)]
                .into_iter()
                .filter(|phi| (0.0..=theta).contains(phi))
                .map(|phi| (phi, (ca * phi.cos() + cb * phi.sin()).abs()))
                .fold(
                    (0.0, f64::NEG_INFINITY),
                    |m, x| if x.1 > m.1 { x } else { m },
                );
            at(best.0)
        }
    }
}

/// Unit vector from spherical coordinates: azimuth phi, polar angle theta (paper 3.1).
pub fn from_spherical(phi: Radians, theta: Radians) -> UnitVec {
    Unit::new_normalize(Vector3::new(
        phi.0.cos() * theta.0.sin(),
        phi.0.sin() * theta.0.sin(),
        theta.0.cos(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn v(x: f64, y: f64, z: f64) -> UnitVec {
        unit(Vector3::new(x, y, z)).unwrap()
    }

    #[test]
    fn a_pair_surely_beyond_a_limit_is_beyond_it_by_its_angle_and_only_near_ones_are_not() {
        let mut rng = crate::model::random::SplitMix::new(11);
        let (mut apart, mut near_limit) = (0, 0);
        for k in 0..20_000 {
            let limit = Radians(0.05 + 1.5 * rng.uniform());
            let test = SurelyBeyond::new(limit);
            // lengths other than 1, and half the pairs within a milliradian of the limit
            let a = rng.direction().into_inner() * (0.5 + rng.uniform());
            let b = if k % 2 == 0 {
                rng.direction().into_inner() * 2.0
            } else {
                let axis = unit(a.cross(&rng.direction())).unwrap();
                let turn = limit.0 + 2e-3 * (rng.uniform() - 0.5);
                rot(&axis, Radians(turn)) * a * 3.0
            };
            let d = angular_distance(&UnitVec::new_normalize(a), &UnitVec::new_normalize(b));
            if test.apart(&a, &b) {
                apart += 1;
                assert!(d.0 > limit.0, "{} against {}", d.0, limit.0);
            } else {
                // not surely apart: within the limit, or beyond it by less than the slack's
                // order of rounding
                assert!(d.0 <= limit.0 + 1e-8, "{} against {}", d.0, limit.0);
                near_limit += usize::from(d.0 > limit.0);
            }
        }
        assert!(apart > 5_000, "{apart}");
        assert!(near_limit < 10, "{near_limit}");
    }

    #[test]
    fn the_nearest_point_of_a_geodesic_lies_on_it_at_the_distance_measured() {
        // 120 degrees about Z from a tilted start; a point 7 degrees off the path, a third of
        // the way along: its nearest point is the path's point a third of the way along
        let a = rot_q(&v(1.0, 0.0, 0.0), Radians(0.3));
        let b = rot_q(&v(0.0, 0.0, 1.0), Radians(120f64.to_radians())) * a;
        let on = rot_q(&v(0.0, 0.0, 1.0), Radians(40f64.to_radians())) * a;
        let axis_off = unit(on * Vector3::new(1.0, 0.0, 0.0)).unwrap();
        let q = rot_q(&axis_off, Radians(7f64.to_radians())) * on;
        let p = nearest_on_geodesic(&q, &a, &b);
        assert!(p.angle_to(&on) < 1e-9, "{}", p.angle_to(&on));
        let d = distance_to_geodesic(&q, &a, &b).0;
        assert!((p.angle_to(&q) - d).abs() < 1e-12);
        // beyond the end: the end itself
        let past = rot_q(&v(0.0, 0.0, 1.0), Radians(150f64.to_radians())) * a;
        assert!(nearest_on_geodesic(&past, &a, &b).angle_to(&b) < 1e-9);
    }

    #[test]
    fn distance_is_accurate_near_zero_and_pi() {
        let a = v(1.0, 0.0, 0.0);
        let b = v(1.0, 1e-9, 0.0);
        assert!((angular_distance(&a, &b).0 - 1e-9).abs() < 1e-18);
        let c = v(-1.0, 1e-9, 0.0);
        assert!((angular_distance(&a, &c).0 - (PI - 1e-9)).abs() < 1e-15);
    }

    #[test]
    fn rot_matches_paper_formula() {
        let n = v(1.0, 2.0, 3.0);
        let th: f64 = 0.7;
        let nn = n.into_inner();
        let nm = Matrix3::new(0.0, -nn.z, nn.y, nn.z, 0.0, -nn.x, -nn.y, nn.x, 0.0);
        let paper = Matrix3::identity() + nm * th.sin() + nm * nm * (1.0 - th.cos());
        let r = rot(&n, Radians(th));
        assert!((r.matrix() - paper).norm() < 1e-14);
        // theta(R) and n(R) recover them
        assert!((matrix_angle(r.matrix()).0 - th).abs() < 1e-14);
        let q = rot_q(&n, Radians(th));
        assert!((rotation_axis(&q).unwrap().into_inner() - nn).norm() < 1e-14);
    }

    #[test]
    fn angle_and_axis_are_safe_near_pi_and_zero() {
        let n = v(0.0, 0.0, 1.0);
        let q = rot_q(&n, Radians(PI - 1e-10));
        assert!((rotation_angle(&q).0 - (PI - 1e-10)).abs() < 1e-12);
        assert!(axis_error(&q, &n).0 < 1e-6);
        let q = rot_q(&n, Radians(1e-9));
        assert!((rotation_angle(&q).0 - 1e-9).abs() < 1e-20);
        assert!(axis_error(&q, &n).0 < 1e-9);
        assert_eq!(rotation_axis(&UnitQuaternion::identity()), None);
        let q = rot_q(&n, Radians(-0.3));
        assert!((signed_angle_about(&q, &n).0 + 0.3).abs() < 1e-14);
    }

    #[test]
    fn bad_vectors_are_rejected() {
        assert!(unit(Vector3::zeros()).is_none());
        assert!(unit(Vector3::new(f64::NAN, 0.0, 1.0)).is_none());
        assert!(orientation_from_xyzw(0.0, 0.0, 0.0, 0.0).is_none());
        assert!(orientation_from_xyzw(0.0, f64::INFINITY, 0.0, 1.0).is_none());
    }

    fn z() -> UnitVec {
        v(0.0, 0.0, 1.0)
    }

    #[test]
    fn a_point_on_the_path_is_at_no_distance_from_it() {
        let a = rot_q(&v(1.0, 0.2, -0.3), Radians(0.4));
        let b = rot_q(&z(), Radians(1.5)) * a;
        for t in [0.0, 0.1, 0.5, 0.9, 1.0] {
            let q = a.slerp(&b, t);
            assert!(distance_to_geodesic(&q, &a, &b).0 < 1e-7, "{t}");
        }
    }

    #[test]
    fn a_point_beyond_the_target_is_at_its_distance_from_the_target() {
        let a = Orientation::identity();
        let b = rot_q(&z(), Radians(1.0));
        // 30 degrees on past the target about the same axis
        let past = rot_q(&z(), Radians(1.0 + 30f64.to_radians()));
        let d = distance_to_geodesic(&past, &a, &b).to_degrees().0;
        assert!((d - 30.0).abs() < 1e-9, "{d}");
        // and before the start: its distance to the start
        let before = rot_q(&z(), Radians(-20f64.to_radians()));
        let d = distance_to_geodesic(&before, &a, &b).to_degrees().0;
        assert!((d - 20.0).abs() < 1e-9, "{d}");
        // off to the side beyond the end
        let q = rot_q(&v(1.0, 0.0, 0.0), Radians(10f64.to_radians())) * past;
        let d = distance_to_geodesic(&q, &a, &b).0;
        assert!((d - q.angle_to(&b)).abs() < 1e-9, "{d}");
    }

    #[test]
    fn a_turn_off_the_middle_of_the_path_is_its_angle_away() {
        let a = rot_q(&v(0.3, -1.0, 0.5), Radians(0.8));
        let b = rot_q(&z(), Radians(PI / 2.0)) * a;
        let mid = a.slerp(&b, 0.5);
        // 10 degrees about x, perpendicular to the path's axis (z), at its midpoint
        let q = rot_q(&v(1.0, 0.0, 0.0), Radians(10f64.to_radians())) * mid;
        let d = distance_to_geodesic(&q, &a, &b).to_degrees().0;
        assert!((d - 10.0).abs() < 1e-9, "{d}");
    }

    #[test]
    fn either_sign_of_a_quaternion_gives_the_same_distance() {
        let a = rot_q(&v(0.1, 0.7, 0.2), Radians(0.3));
        let b = rot_q(&v(1.0, 1.0, 0.0), Radians(2.0)) * a;
        let q = rot_q(&v(-0.4, 0.2, 1.0), Radians(0.9)) * a;
        let neg = |x: &Orientation| Orientation::new_unchecked(-x.into_inner());
        let d = distance_to_geodesic(&q, &a, &b).0;
        assert!(d > 0.1);
        for (q2, a2, b2) in [(neg(&q), a, b), (q, neg(&a), b), (q, a, neg(&b))] {
            assert!((distance_to_geodesic(&q2, &a2, &b2).0 - d).abs() < 1e-12);
        }
    }

    #[test]
    fn a_path_of_one_point_is_measured_to_that_point() {
        let a = rot_q(&v(0.0, 1.0, 0.0), Radians(0.5));
        let q = rot_q(&z(), Radians(0.25)) * a;
        assert!((distance_to_geodesic(&q, &a, &a).0 - 0.25).abs() < 1e-12);
    }
}
