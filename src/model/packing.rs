//! Packings of points on the sphere: rotor magnets (body frame) and stator coils (world frame).
//! A semi-regular packing is a rotation group, generator points and an optional cap; the
//! built-in `prototype` reconstructs the paper's motor (80 magnets with octahedral symmetry,
//! 16 coils from an icosahedral packing, one on -Z). The compatibility report compares "center
//! lengths" (paper section 2.1).

use crate::model::geometry::{angular_distance, unit, Degrees, Radians, UnitVec};
use crate::model::symmetry::{orbit, Group};
use nalgebra::Vector3;
use serde::Serialize;

/// Points on the unit sphere.
#[derive(Debug, Clone, PartialEq)]
pub struct Packing {
    /// The points in their order: index `i` is magnet (body frame) or coil (world frame) `i`.
    pub points: Vec<UnitVec>,
}

/// A semi-regular packing: the union of the orbits of generator points under a group,
/// optionally kept only inside a spherical cap.
#[derive(Debug, Clone)]
pub struct SemiRegular {
    /// The rotation group whose orbits make the packing.
    pub group: Group,
    /// The generator points; each contributes its orbit under `group`, in this order.
    pub generators: Vec<UnitVec>,
    /// Keeps only the points inside this cap (a stator cap); `None` keeps the whole sphere.
    pub cap: Option<Cap>,
}

/// A spherical cap: the points within `radius` of `center`.
#[derive(Debug, Clone, Copy)]
pub struct Cap {
    /// The cap's centre on the sphere.
    pub center: UnitVec,
    /// Its angular radius (radians).
    pub radius: Radians,
}

impl Cap {
    /// Whether `p` is within the cap's radius of its centre (1e-9 rad of slack, so that
    /// points on the rim count).
    pub fn contains(&self, p: &UnitVec) -> bool {
        angular_distance(&self.center, p).0 <= self.radius.0 + 1e-9
    }
}

impl SemiRegular {
    /// The points: orbits in generator order, duplicates (shared by two orbits) removed.
    pub fn points(&self) -> Packing {
        let mut pts: Vec<UnitVec> = Vec::new();
        for g in &self.generators {
            for p in orbit(self.group, g) {
                let inside = self.cap.as_ref().is_none_or(|c| c.contains(&p));
                if inside
                    && !pts
                        .iter()
                        .any(|q| (q.into_inner() - p.into_inner()).norm() < 1e-9)
                {
                    pts.push(p);
                }
            }
        }
        Packing { points: pts }
    }
}

impl Packing {
    /// The number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether there are no points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The first two points (indices, ascending) closer than `tol` (chord length), if any:
    /// coincident magnets or coils. Sorted by x and swept, so it stays fast for large packings.
    pub fn coincident(&self, tol: f64) -> Option<(usize, usize)> {
        let mut order: Vec<usize> = (0..self.points.len()).collect();
        order.sort_by(|&a, &b| self.points[a].x.total_cmp(&self.points[b].x));
        let mut best: Option<(usize, usize)> = None;
        for (k, &a) in order.iter().enumerate() {
            for &b in &order[k + 1..] {
                if self.points[b].x - self.points[a].x >= tol {
                    break;
                }
                if (self.points[a].into_inner() - self.points[b].into_inner()).norm() < tol {
                    let pair = (a.min(b), a.max(b));
                    best = Some(best.map_or(pair, |p| p.min(pair)));
                }
            }
        }
        best
    }

    /// Smallest angular distance between two points (pi for fewer than two points); see
    /// [`min_separation`].
    pub fn min_separation(&self) -> Radians {
        min_separation(&self.points)
    }

    /// The distinct "center lengths": pairwise angular distances, merged when within `tol` of
    /// the previous one (sorted ascending), each with how many pairs share it. Up to
    /// [`EXACT_CENTER_LENGTHS`] points every distance is kept and sorted; above, the distances
    /// are counted in bins of `tol / 16` (memory bounded by the bins, not the pairs) and merged
    /// bin by bin, so a merged length may differ from the exact one by a bin.
    pub fn center_lengths(&self, tol: Radians) -> Vec<(Radians, usize)> {
        if self.points.len() > EXACT_CENTER_LENGTHS {
            return binned_center_lengths(&self.points, tol);
        }
        let mut d: Vec<f64> = Vec::new();
        for (a, p) in self.points.iter().enumerate() {
            for q in &self.points[a + 1..] {
                d.push(angular_distance(p, q).0);
            }
        }
        d.sort_by(f64::total_cmp);
        let mut out: Vec<(f64, f64, usize)> = Vec::new(); // (first, sum, count)
        for x in d {
            match out.last_mut() {
                Some((first, sum, n)) if x - *first <= tol.0 => {
                    *sum += x;
                    *n += 1;
                }
                _ => out.push((x, x, 1)),
            }
        }
        out.into_iter()
            .map(|(_, s, n)| (Radians(s / n as f64), n))
            .collect()
    }
}

/// Above this many points [`Packing::center_lengths`] bins the distances instead of keeping
/// them all (2,000 points: 2 million pairs, 16 MB).
pub const EXACT_CENTER_LENGTHS: usize = 2_000;

/// The smallest angular distance between two of `points` (pi for fewer than two), as the
/// all-pairs minimum of [`angular_distance`] gives it, in about n log n: the points sorted by x
/// and swept (two points closer than the best chord so far are closer in x too); the pairs
/// whose chord is within a relative 1e-9 of the shortest are then measured with
/// [`angular_distance`] itself, so the value is the all-pairs one to the last bit.
pub fn min_separation(points: &[UnitVec]) -> Radians {
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&a, &b| points[a].x.total_cmp(&points[b].x));
    let chord = |a: usize, b: usize| (points[a].into_inner() - points[b].into_inner()).norm();
    let mut best = f64::INFINITY;
    for (k, &a) in order.iter().enumerate() {
        for &b in &order[k + 1..] {
            if points[b].x - points[a].x > best {
                break;
            }
            best = best.min(chord(a, b));
        }
    }
    if !best.is_finite() {
        return Radians(std::f64::consts::PI);
    }
    let near = best * (1.0 + 1e-9) + 1e-300;
    let mut m = std::f64::consts::PI;
    for (k, &a) in order.iter().enumerate() {
        for &b in &order[k + 1..] {
            if points[b].x - points[a].x > near {
                break;
            }
            if chord(a, b) <= near {
                m = m.min(angular_distance(&points[a], &points[b]).0);
            }
        }
    }
    Radians(m)
}

/// [`Packing::center_lengths`] for large packings: the pairwise distances (in parallel, rows
/// of the pair triangle) counted in bins of `tol / 16` with their sums, then merged as the
/// exact version merges sorted distances, a bin at a time.
fn binned_center_lengths(points: &[UnitVec], tol: Radians) -> Vec<(Radians, usize)> {
    use rayon::prelude::*;
    let width = (tol.0 / 16.0).max(1e-9);
    let bins = (std::f64::consts::PI / width) as usize + 1;
    let bin_of = |d: f64| ((d / width) as usize).min(bins - 1);
    let (count, sum) = (0..points.len())
        .into_par_iter()
        .fold(
            || (vec![0usize; bins], vec![0.0f64; bins]),
            |(mut c, mut s), a| {
                for q in &points[a + 1..] {
                    let d = points[a].dot(q).clamp(-1.0, 1.0).acos();
                    let k = bin_of(d);
                    c[k] += 1;
                    s[k] += d;
                }
                (c, s)
            },
        )
        .reduce(
            || (vec![0usize; bins], vec![0.0f64; bins]),
            |(mut c, mut s), (c2, s2)| {
                for k in 0..bins {
                    c[k] += c2[k];
                    s[k] += s2[k];
                }
                (c, s)
            },
        );
    let mut out: Vec<(f64, f64, usize)> = Vec::new(); // (first, sum, count)
    for k in (0..bins).filter(|&k| count[k] > 0) {
        let first = k as f64 * width;
        match out.last_mut() {
            Some((f, s, n)) if first - *f <= tol.0 => {
                *s += sum[k];
                *n += count[k];
            }
            _ => out.push((first, sum[k], count[k])),
        }
    }
    out.into_iter()
        .map(|(_, s, n)| (Radians(s / n as f64), n))
        .collect()
}

/// One line of the compatibility report: a stator center length and the nearest rotor one.
#[derive(Debug, Clone, Serialize)]
pub struct CenterLengthMatch {
    /// The stator center length (an angle between two coils), degrees.
    pub stator_deg: f64,
    /// How many coil pairs are that far apart.
    pub stator_pairs: usize,
    /// The rotor center length nearest to it, degrees (NaN when the rotor has none).
    pub nearest_rotor_deg: f64,
    /// `|nearest_rotor_deg - stator_deg|`, degrees.
    pub mismatch_deg: f64,
}

/// The packing report of `spherestep packing`.
#[derive(Debug, Clone, Serialize)]
pub struct PackingReport {
    /// The number of rotor magnets.
    pub rotor_magnets: usize,
    /// The number of stator coils.
    pub stator_coils: usize,
    /// The smallest angle between two magnets, degrees.
    pub rotor_min_separation_deg: f64,
    /// The smallest angle between two coils, degrees.
    pub stator_min_separation_deg: f64,
    /// The angle from -Z (the cap's pole) to the furthest coil, degrees.
    pub stator_cap_radius_deg: f64,
    /// The rotor's distinct center lengths (merged within [`CENTER_LENGTH_TOL`]), ascending,
    /// degrees.
    pub rotor_center_lengths_deg: Vec<f64>,
    /// Each distinct stator center length, ascending, with its nearest rotor one.
    pub stator_center_lengths: Vec<CenterLengthMatch>,
    /// The largest `mismatch_deg` of `stator_center_lengths`, degrees (0 with no coils).
    pub worst_mismatch_deg: f64,
}

/// Tolerance used to merge nearly equal center lengths in the report.
pub const CENTER_LENGTH_TOL: Degrees = Degrees(0.05);

/// Builds the compatibility report of a rotor and a stator packing.
pub fn report(rotor: &Packing, stator: &Packing) -> PackingReport {
    let tol = CENTER_LENGTH_TOL.to_radians();
    let rl = rotor.center_lengths(tol);
    let sl = stator.center_lengths(tol);
    let matches: Vec<CenterLengthMatch> = sl
        .iter()
        .map(|(s, n)| {
            let nearest = rl
                .iter()
                .map(|(r, _)| r.0)
                .min_by(|a, b| (a - s.0).abs().total_cmp(&(b - s.0).abs()))
                .unwrap_or(f64::NAN);
            CenterLengthMatch {
                stator_deg: s.0.to_degrees(),
                stator_pairs: *n,
                nearest_rotor_deg: nearest.to_degrees(),
                mismatch_deg: (nearest - s.0).abs().to_degrees(),
            }
        })
        .collect();
    let down = unit(Vector3::new(0.0, 0.0, -1.0)).expect("constant");
    let cap = stator
        .points
        .iter()
        .map(|p| angular_distance(p, &down).0)
        .fold(0.0, f64::max);
    PackingReport {
        rotor_magnets: rotor.len(),
        stator_coils: stator.len(),
        rotor_min_separation_deg: rotor.min_separation().0.to_degrees(),
        stator_min_separation_deg: stator.min_separation().0.to_degrees(),
        stator_cap_radius_deg: cap.to_degrees(),
        rotor_center_lengths_deg: rl.iter().map(|(r, _)| r.0.to_degrees()).collect(),
        worst_mismatch_deg: matches.iter().map(|m| m.mismatch_deg).fold(0.0, f64::max),
        stator_center_lengths: matches,
    }
}

// ---------------------------------------------------------------------------------------------
// The built-in prototype (a reconstruction: the paper does not publish coordinates).

/// Rotor magnet coordinates of the built-in prototype, as generated by
/// [`generate_prototype_rotor`] and kept in the repository for review.
pub const PROTOTYPE_ROTOR_CSV: &str = include_str!("../../scenarios/prototype/rotor.csv");
/// Stator coil coordinates of the built-in prototype, from [`generate_prototype_stator`].
pub const PROTOTYPE_STATOR_CSV: &str = include_str!("../../scenarios/prototype/stator.csv");

/// Parses a points CSV with header `x,y,z` (one unit vector per row).
pub fn parse_points_csv(text: &str) -> Result<Packing, String> {
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .from_reader(text.as_bytes());
    let headers = rdr.headers().map_err(|e| format!("line 1: {e}"))?.clone();
    check_header(&headers, &["x", "y", "z"], "point")?;
    let mut pts = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| format!("line {}: {e}", csv_line(e.position())))?;
        let line = csv_line(rec.position());
        if rec.len() != 3 {
            return Err(format!("line {line}: expected 3 columns x,y,z"));
        }
        let mut c = [0.0; 3];
        for (k, f) in rec.iter().enumerate() {
            c[k] = f
                .trim()
                .parse::<f64>()
                .map_err(|_| format!("line {line}: '{f}' is not a number"))?;
        }
        let u = unit(Vector3::new(c[0], c[1], c[2]))
            .ok_or_else(|| format!("line {line}: zero or non-finite vector"))?;
        pts.push(u);
    }
    Ok(Packing { points: pts })
}

/// The line number of a CSV record (1-based; 0 when unknown).
pub(crate) fn csv_line(pos: Option<&csv::Position>) -> u64 {
    pos.map(|p| p.line()).unwrap_or(0)
}

/// Checks that a CSV's first row is the expected header (names trimmed, any case). A header is
/// required, never guessed: a file whose first row is data would otherwise lose that `row`
/// silently and shift every index after it.
pub(crate) fn check_header(
    headers: &csv::StringRecord,
    expected: &[&str],
    row: &str,
) -> Result<(), String> {
    let found: Vec<String> = headers.iter().map(|h| h.trim().to_lowercase()).collect();
    if found
        .iter()
        .map(String::as_str)
        .eq(expected.iter().copied())
    {
        return Ok(());
    }
    let got = headers.iter().collect::<Vec<_>>().join(",");
    let hint = if !headers.is_empty() && headers.iter().all(|h| h.trim().parse::<f64>().is_ok()) {
        format!(" (this is a row of numbers: add the header line first, or its {row} is lost)")
    } else {
        String::new()
    };
    Err(format!(
        "line 1: expected the header `{}`, got `{got}`{hint}",
        expected.join(",")
    ))
}

/// Writes a packing as the points CSV read by [`parse_points_csv`] (17 significant digits, so
/// that the numbers read back exactly).
pub fn points_csv(p: &Packing) -> String {
    let mut s = String::from("x,y,z\n");
    for u in &p.points {
        s.push_str(&format!("{:.17e},{:.17e},{:.17e}\n", u.x, u.y, u.z));
    }
    s
}

/// The prototype rotor magnets (embedded coordinates).
pub fn prototype_rotor() -> Packing {
    parse_points_csv(PROTOTYPE_ROTOR_CSV).expect("embedded prototype rotor is valid")
}

/// The prototype stator coils (embedded coordinates).
pub fn prototype_stator() -> Packing {
    parse_points_csv(PROTOTYPE_STATOR_CSV).expect("embedded prototype stator is valid")
}

/// Number of stator coils in the prototype.
pub const PROTOTYPE_COILS: usize = 16;

/// Generates the prototype stator from the icosahedral semi-regular packing of 62 points
/// (the vertices, edge midpoints and face centres of an icosahedron with a vertex on -Z): the
/// vertex on -Z, the 5 edge midpoints around it (31.7 degrees out), the 5 midpoints of the
/// edges of its pentagon (58.3 degrees) and the 5 face centres of the next ring (79.2
/// degrees), turned about Z so that one rim coil lies towards +Y. The cap is 79.2 degrees
/// (less than a hemisphere) and the coils are 20.9 degrees apart at the least, room for 2 inch
/// coils around a 12 inch ball. Why the rim: a pivot step turns the ball about a coil's axis,
/// so the paper's 15 degree bound about Y (Figure 8) needs a coil within 15 degrees of the Y
/// axis; a compact cap (58 degrees) cannot do better than 32 degrees.
pub fn generate_prototype_stator() -> Packing {
    let t = 2.0f64.atan(); // polar angle of a vertex next to the one on +Z
    let v0 = Vector3::new(0.0, 0.0, 1.0);
    let v1 = Vector3::new(t.sin(), 0.0, t.cos());
    let a = 2.0 * std::f64::consts::PI / 5.0;
    let v2 = Vector3::new(t.sin() * a.cos(), t.sin() * a.sin(), t.cos());
    let u = |v: Vector3<f64>| unit(v).expect("constant");
    let full = SemiRegular {
        group: Group::I,
        generators: vec![u(v0), u(v0 + v1), u(v0 + v1 + v2)],
        cap: None,
    }
    .points();
    let down = u(Vector3::new(0.0, 0.0, -1.0));
    let rings_deg = [0.0, 31.717, 58.283, 79.188];
    let mut pts: Vec<UnitVec> = full
        .points
        .into_iter()
        .filter(|p| {
            let d = angular_distance(p, &down).0.to_degrees();
            rings_deg.iter().any(|r| (d - r).abs() < 0.01)
        })
        .collect();
    // Turn about Z (the smallest turn) so that a rim coil points towards +Y.
    let rim_az = pts
        .iter()
        .filter(|p| angular_distance(p, &down).0.to_degrees() > 79.0)
        .map(|p| {
            let mut turn = std::f64::consts::FRAC_PI_2 - p.y.atan2(p.x);
            while turn > std::f64::consts::PI {
                turn -= 2.0 * std::f64::consts::PI;
            }
            while turn <= -std::f64::consts::PI {
                turn += 2.0 * std::f64::consts::PI;
            }
            turn
        })
        .min_by(|a, b| a.abs().total_cmp(&b.abs()))
        .unwrap_or(0.0);
    let turn = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), rim_az);
    for p in pts.iter_mut() {
        *p = UnitVec::new_normalize(turn * p.into_inner());
    }
    // Sort by distance from -Z, then by azimuth, so that indices are stable and readable.
    pts.sort_by(|p, q| {
        let dp = angular_distance(p, &down).0;
        let dq = angular_distance(q, &down).0;
        let key = |d: f64| (d * 1e6).round();
        key(dp)
            .total_cmp(&key(dq))
            .then(azimuth(p).total_cmp(&azimuth(q)))
    });
    debug_assert_eq!(pts.len(), PROTOTYPE_COILS);
    Packing { points: pts }
}

fn azimuth(p: &UnitVec) -> f64 {
    let a = p.y.atan2(p.x);
    let a = if a < -1e-9 {
        a + 2.0 * std::f64::consts::PI
    } else {
        a
    };
    (a * 1e9).round() / 1e9
}

/// Generates the prototype rotor: 80 magnets with octahedral symmetry, the 8 cube vertices plus
/// three generic 24-point orbits whose generators spread the 80 points as evenly as possible
/// (they minimise a Riesz energy, sum of 1/|p - q|^s, from a fixed set of starting points; the
/// most evenly spread result, largest minimum separation, is kept).
pub fn generate_prototype_rotor() -> Packing {
    let cube = unit(Vector3::new(1.0, 1.0, 1.0)).expect("constant");
    let mut best: Option<(f64, Vec<UnitVec>)> = None;
    // Deterministic starts: generators spread in the fundamental region near +Z.
    for start in 0..12 {
        let mut gens: Vec<UnitVec> = (0..3)
            .map(|k| {
                let i = (start * 3 + k) as f64;
                let phi = 0.1 + (i * 0.618_033_988_749_895).fract() * std::f64::consts::FRAC_PI_2;
                let theta = 0.15 + (i * 0.414_213_562_373_095).fract() * 0.8;
                crate::model::geometry::from_spherical(Radians(phi), Radians(theta))
            })
            .collect();
        relax_rotor(&cube, &mut gens);
        let p = rotor_from_generators(&cube, &gens);
        if p.len() != 80 {
            continue;
        }
        let sep = p.min_separation().0;
        if best.as_ref().is_none_or(|(b, _)| sep > *b + 1e-12) {
            best = Some((sep, gens));
        }
    }
    let (_, gens) = best.expect("at least one start gives 80 distinct magnets");
    rotor_from_generators(&cube, &gens)
}

fn rotor_from_generators(cube: &UnitVec, gens: &[UnitVec]) -> Packing {
    let mut all = vec![*cube];
    all.extend_from_slice(gens);
    SemiRegular {
        group: Group::O,
        generators: all,
        cap: None,
    }
    .points()
}

/// Riesz-energy descent on the generators: the force on each generator from all other points
/// (the energy gradient of the whole symmetric configuration is the orbit sum of equal copies).
fn relax_rotor(cube: &UnitVec, gens: &mut [UnitVec]) {
    for (s, iters) in [(4.0, 400), (12.0, 600)] {
        let mut step = 0.02;
        for _ in 0..iters {
            let pts = rotor_from_generators(cube, gens);
            let mut moved = 0.0f64;
            for g in gens.iter_mut() {
                let p = g.into_inner();
                let mut f = Vector3::zeros();
                let mut fmax = 0.0f64;
                for q in &pts.points {
                    let d = p - q.into_inner();
                    let r2 = d.norm_squared();
                    if r2 < 1e-18 {
                        continue;
                    }
                    let w = 1.0 / r2.powf(s / 2.0 + 1.0);
                    fmax = fmax.max(w * r2.sqrt());
                    f += d * w;
                }
                let tangent = f - p * p.dot(&f);
                let n = tangent.norm();
                if n > 0.0 && fmax > 0.0 {
                    let dx = tangent * (step / fmax.max(n));
                    moved = moved.max(dx.norm());
                    *g = UnitVec::new_normalize(p + dx);
                }
            }
            step *= 0.995;
            if moved < 1e-13 {
                break;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embedded_prototype_is_what_the_generators_make() {
        let rotor = generate_prototype_rotor();
        let stator = generate_prototype_stator();
        assert_eq!(points_csv(&rotor), PROTOTYPE_ROTOR_CSV);
        assert_eq!(points_csv(&stator), PROTOTYPE_STATOR_CSV);
    }

    /// Points spread on the sphere (a Fibonacci spiral) with a seeded jitter.
    fn spiral(n: usize, seed: u64) -> Vec<UnitVec> {
        let g = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let mut state = seed;
        let mut jitter = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.02
        };
        (0..n)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
                let r = (1.0 - z * z).sqrt();
                let t = g * i as f64;
                unit(Vector3::new(
                    r * t.cos() + jitter(),
                    r * t.sin() + jitter(),
                    z,
                ))
                .unwrap()
            })
            .collect()
    }

    #[test]
    fn min_separation_is_the_all_pairs_minimum_to_the_bit() {
        let brute = |p: &[UnitVec]| {
            let mut m = std::f64::consts::PI;
            for (a, x) in p.iter().enumerate() {
                for y in &p[a + 1..] {
                    m = m.min(angular_distance(x, y).0);
                }
            }
            m
        };
        for (n, seed) in [(0, 1), (1, 1), (2, 3), (80, 4), (500, 5), (1500, 6)] {
            let p = spiral(n, seed);
            assert_eq!(min_separation(&p).0.to_bits(), brute(&p).to_bits(), "n {n}");
        }
        let rotor = prototype_rotor();
        assert_eq!(
            rotor.min_separation().0.to_bits(),
            brute(&rotor.points).to_bits()
        );
    }

    #[test]
    fn binned_center_lengths_agree_with_the_exact_ones() {
        // 300 points: the exact lengths, and the binned ones from the same distances; the
        // binned merge starts each length at its bin, so the two can split a run of close
        // lengths differently, but every pair is counted once and the lengths cover the same
        // range to within a bin
        let tol = CENTER_LENGTH_TOL.to_radians();
        let p = Packing {
            points: spiral(300, 7),
        };
        let exact = p.center_lengths(tol);
        let binned = binned_center_lengths(&p.points, tol);
        let pairs = 300 * 299 / 2;
        assert_eq!(exact.iter().map(|l| l.1).sum::<usize>(), pairs);
        assert_eq!(binned.iter().map(|l| l.1).sum::<usize>(), pairs);
        let bin = tol.0 / 16.0;
        let (e0, b0) = (exact[0].0 .0, binned[0].0 .0);
        assert!((e0 - b0).abs() < tol.0 + bin, "{e0} {b0}");
        let (e1, b1) = (exact.last().unwrap().0 .0, binned.last().unwrap().0 .0);
        assert!((e1 - b1).abs() < tol.0 + bin, "{e1} {b1}");
        // every exact length has a binned one within the merge tolerance and a bin
        for (e, _) in &exact {
            let nearest = binned
                .iter()
                .map(|(b, _)| (b.0 - e.0).abs())
                .fold(f64::INFINITY, f64::min);
            assert!(nearest < tol.0 + bin, "{} deg", e.0.to_degrees());
        }
    }

    #[test]
    fn prototype_facts() {
        let rotor = prototype_rotor();
        let stator = prototype_stator();
        assert_eq!(rotor.len(), 80);
        assert_eq!(stator.len(), 16);
        // one coil on -Z, all in a cap smaller than a hemisphere, one within 11 degrees of Y
        assert!((stator.points[0].z + 1.0).abs() < 1e-12);
        assert!(stator.points.iter().all(|p| p.z < -0.15));
        let y = unit(Vector3::y()).unwrap();
        let near_y = stator
            .points
            .iter()
            .map(|p| angular_distance(p, &y).0.to_degrees())
            .fold(180.0, f64::min);
        assert!((near_y - 10.812).abs() < 0.01, "{near_y}");
        // octahedral symmetry: every rotation of O maps the rotor onto itself
        for g in Group::O.elements() {
            for p in &rotor.points {
                let q = g * p.into_inner();
                assert!(rotor
                    .points
                    .iter()
                    .any(|r| (r.into_inner() - q).norm() < 1e-9));
            }
        }
        // evenly spread: 80 points cannot be more than ~25.6 degrees apart; ours are close
        let sep = rotor.min_separation().0.to_degrees();
        assert!(sep > 20.0 && sep < 25.7, "rotor separation {sep}");
        let ssep = stator.min_separation().0.to_degrees();
        assert!((ssep - 20.905).abs() < 0.01, "stator separation {ssep}");
    }
}
