//! A pair well's profile: f(u) = g(d) / sin d, the factor that turns p x s into one pair's
//! torque, as a function of u = 1 - cos d = 1 - p . s, tabulated once per well as piecewise
//! polynomials fitted at Chebyshev nodes. A torque evaluation then needs no square root, no
//! arctangent and no exponential: a dot product, a cross product and one short polynomial. A
//! profile is kept only where it matches the well's own formula everywhere within the cut-off
//! to [`TOLERANCE`]; otherwise the well is evaluated exactly.

/// The largest error a profile may have anywhere within the cut-off, relative to |f| there
/// (and to 1e-3 times the largest |f| where f is near zero). The wells' own formulas carry
/// a few times 1e-15 (the angle from u, the exponential); 1e-13 is far below anything a settle
/// or a plan can see (the fast path's tolerances are 1e-2, the reference's 1e-10).
pub(crate) const TOLERANCE: f64 = 1e-13;
/// See [`TOLERANCE`].
const FLOOR: f64 = 1e-3;
/// Polynomial degree of each piece.
const DEGREE: usize = 7;
/// Pieces tried: 8, 16, ... up to this; a well that needs more is evaluated exactly.
const MAX_PIECES: usize = 1024;
/// Checks of the fit per piece, between its nodes and at both ends.
const CHECKS: usize = 16;

/// f(u) on [0, u_max] as `pieces` polynomials of degree 7 in z in [-1, 1].
#[derive(Debug, Clone)]
pub(crate) struct Profile {
    u_max: f64,
    /// pieces / u_max
    inv_h: f64,
    /// Monomial coefficients in the piece's own z = 2 (u / h - i) - 1, lowest first.
    coeffs: Vec<[f64; DEGREE + 1]>,
}

impl Profile {
    /// The profile of `f` (finite on [0, u_max]) with the fewest pieces that meets
    /// [`TOLERANCE`], or `None`: a kink or a singularity that no polynomial follows, or a
    /// non-finite value.
    pub(crate) fn fit(f: impl Fn(f64) -> f64, u_max: f64) -> Option<Profile> {
        if !(u_max > 0.0 && u_max <= 2.0) {
            return None;
        }
        let mut pieces = 8;
        while pieces <= MAX_PIECES {
            let h = u_max / pieces as f64;
            let coeffs: Option<Vec<_>> = (0..pieces)
                .map(|i| chebyshev_fit(&f, i as f64 * h, (i + 1) as f64 * h))
                .collect();
            let p = Profile {
                u_max,
                inv_h: 1.0 / h,
                coeffs: coeffs?,
            };
            if p.meets_tolerance(&f) {
                return Some(p);
            }
            pieces *= 2;
        }
        None
    }

    /// Whether the profile is within [`TOLERANCE`] of `f` at [`CHECKS`] points of each piece.
    fn meets_tolerance(&self, f: &impl Fn(f64) -> f64) -> bool {
        let h = self.u_max / self.coeffs.len() as f64;
        let mut points = Vec::with_capacity(self.coeffs.len() * CHECKS + 1);
        for i in 0..self.coeffs.len() {
            for j in 0..CHECKS {
                points.push((i as f64 + j as f64 / CHECKS as f64) * h);
            }
        }
        points.push(self.u_max);
        let values: Vec<f64> = points.iter().map(|&u| f(u)).collect();
        if values.iter().any(|v| !v.is_finite()) {
            return false;
        }
        let largest = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        points
            .iter()
            .zip(&values)
            .all(|(&u, &v)| (self.value(u) - v).abs() <= TOLERANCE * v.abs().max(FLOOR * largest))
    }

    /// f(u): 0 beyond u_max (the cut-off), the last piece continued for u < 0 by rounding.
    #[inline(always)]
    pub(crate) fn value(&self, u: f64) -> f64 {
        if u > self.u_max {
            return 0.0;
        }
        let (c, z) = self.piece(u);
        // Estrin's scheme: a shorter chain of dependent operations than Horner's
        let z2 = z * z;
        let z4 = z2 * z2;
        let low = (c[0] + c[1] * z) + (c[2] + c[3] * z) * z2;
        let high = (c[4] + c[5] * z) + (c[6] + c[7] * z) * z2;
        low + high * z4
    }

    /// f(u) and df/du (both 0 beyond u_max).
    #[inline]
    pub(crate) fn value_and_slope(&self, u: f64) -> (f64, f64) {
        if u > self.u_max {
            return (0.0, 0.0);
        }
        let (c, z) = self.piece(u);
        let (mut value, mut slope) = (c[DEGREE], 0.0);
        for k in (0..DEGREE).rev() {
            slope = slope * z + value;
            value = value * z + c[k];
        }
        // dz/du = 2 / h
        (value, slope * 2.0 * self.inv_h)
    }

    /// The coefficients of the piece holding u and u's z in it.
    #[inline(always)]
    fn piece(&self, u: f64) -> (&[f64; DEGREE + 1], f64) {
        let t = u * self.inv_h;
        // `as` saturates: a u rounded below 0 falls in piece 0, u_max itself in the last
        let i = (t as usize).min(self.coeffs.len() - 1);
        (&self.coeffs[i], 2.0 * (t - i as f64) - 1.0)
    }
}

/// The polynomial of degree [`DEGREE`] through f at the Chebyshev nodes of [a, b], as monomial
/// coefficients in z = (2u - a - b) / (b - a); `None` if f is not finite there.
fn chebyshev_fit(f: &impl Fn(f64) -> f64, a: f64, b: f64) -> Option<[f64; DEGREE + 1]> {
    const N: usize = DEGREE + 1;
    let angle =
        |k: usize, i: usize| (k * (2 * i + 1)) as f64 * std::f64::consts::PI / (2 * N) as f64;
    let mut values = [0.0; N];
    for (i, v) in values.iter_mut().enumerate() {
        *v = f(0.5 * (a + b) + 0.5 * (b - a) * angle(1, i).cos());
        if !v.is_finite() {
            return None;
        }
    }
    // Chebyshev coefficients by the discrete cosine transform at the nodes ...
    let mut cheb = [0.0; N];
    for (k, ck) in cheb.iter_mut().enumerate() {
        let sum: f64 = (0..N).map(|i| values[i] * angle(k, i).cos()).sum();
        *ck = sum * if k == 0 { 1.0 } else { 2.0 } / N as f64;
    }
    // ... summed as monomials: T_0 = 1, T_1 = z, T_{k+1} = 2 z T_k - T_{k-1}
    let (mut previous, mut current) = ([0.0; N], [0.0; N]);
    previous[0] = 1.0;
    current[1] = 1.0;
    let mut coeffs = [0.0; N];
    for j in 0..N {
        coeffs[j] = cheb[0] * previous[j] + cheb[1] * current[j];
    }
    for &ck in &cheb[2..] {
        let mut next = [0.0; N];
        for j in 0..N {
            next[j] = if j > 0 { 2.0 * current[j - 1] } else { 0.0 } - previous[j];
            coeffs[j] += ck * next[j];
        }
        (previous, current) = (current, next);
    }
    Some(coeffs)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gaussian_f(u: f64) -> f64 {
        // k = 0.25 J, sigma = 10 degrees
        let s2 = 10f64.to_radians().powi(2);
        let d = 2.0 * (0.5 * u).sqrt().asin();
        let sin_d = (u * (2.0 - u)).sqrt();
        let d_over_sin = if sin_d < 1e-7 { 1.0 } else { d / sin_d };
        0.25 / s2 * d_over_sin * (-0.5 * d * d / s2).exp()
    }

    #[test]
    fn a_gaussian_profile_matches_its_formula_and_slope() {
        let u_max = 1.0 - 30f64.to_radians().cos();
        let p = Profile::fit(gaussian_f, u_max).expect("a smooth well has a profile");
        for j in 0..=1000 {
            let u = u_max * j as f64 / 1000.0;
            let exact = gaussian_f(u);
            assert!((p.value(u) - exact).abs() <= TOLERANCE * exact, "u = {u}");
            let (v, slope) = p.value_and_slope(u);
            assert!((v - exact).abs() <= TOLERANCE * exact);
            if j > 0 {
                let h = 1e-6;
                let numeric = (gaussian_f(u + h) - gaussian_f(u - h)) / (2.0 * h);
                assert!(
                    (slope - numeric).abs() < 1e-6 * numeric.abs(),
                    "slope at u = {u}"
                );
            }
        }
        assert_eq!(p.value(u_max * (1.0 + 1e-12)), 0.0);
    }

    #[test]
    fn a_kink_has_no_profile() {
        assert!(Profile::fit(|u: f64| (u - 0.05).abs(), 0.134).is_none());
        assert!(Profile::fit(|u: f64| 1.0 / (u - 0.05), 0.134).is_none());
    }
}
