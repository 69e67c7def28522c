//! The seed layouts of the design search: `n` points in a cap (or over the whole sphere, a
//! cap of 180 degrees) drawn from a [`Family`]: the scenario's own packing, the vertices of
//! Platonic and Archimedean solids turned so that one vertex sits on the cap's axis (the `n`
//! nearest the axis, if they all lie in the cap), a Fibonacci spiral even in area over the
//! cap, and a Tammes-like packing (the spiral's points repelled apart, kept in the cap).

use super::Family;
use crate::model::geometry::{Radians, UnitVec};
use nalgebra::{Rotation3, Vector3};

/// Where a family's points go: `n` of them within `cap` of `axis`.
#[derive(Debug, Clone, Copy)]
pub struct Region {
    /// The cap's axis.
    pub axis: UnitVec,
    /// The cap's half-angle (180 degrees: the whole sphere).
    pub cap: Radians,
}

impl Region {
    /// Whether `p` lies in the cap (within 1e-9 radians of its edge).
    pub fn contains(&self, p: &UnitVec) -> bool {
        p.dot(&self.axis).clamp(-1.0, 1.0).acos() <= self.cap.0 + 1e-9
    }

    /// `p` moved onto the cap's edge along its great circle from the axis, if it lies outside.
    pub fn clamp(&self, p: &UnitVec) -> UnitVec {
        let off = p.dot(&self.axis).clamp(-1.0, 1.0).acos();
        if off <= self.cap.0 {
            return *p;
        }
        let side = p.into_inner() - self.axis.into_inner() * p.dot(&self.axis);
        let side = if side.norm() < 1e-12 {
            perpendicular(&self.axis)
        } else {
            side.normalize()
        };
        UnitVec::new_normalize(self.axis.into_inner() * self.cap.0.cos() + side * self.cap.0.sin())
    }
}

/// A unit vector perpendicular to `a` (deterministic).
pub fn perpendicular(a: &UnitVec) -> Vector3<f64> {
    let helper = if a.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    a.cross(&helper).normalize()
}

/// `n` points of `family` in `region`; `own` is the scenario's packing. `None` when the
/// family has no layout of `n` points there (another count, or vertices outside the cap).
pub fn seed_points(
    family: Family,
    n: usize,
    region: &Region,
    own: &[UnitVec],
) -> Option<Vec<UnitVec>> {
    if n == 0 {
        return None;
    }
    match family {
        Family::Scenario => {
            (own.len() == n && own.iter().all(|p| region.contains(p))).then(|| own.to_vec())
        }
        Family::Platonic => solid_points(&platonic(), n, region),
        Family::Archimedean => solid_points(&archimedean(), n, region),
        Family::Fibonacci => Some(fibonacci(n, region)),
        Family::Tammes => Some(tammes(n, region, 300)),
    }
}

/// A rotation taking the z axis onto `axis`.
fn frame(axis: &UnitVec) -> Rotation3<f64> {
    Rotation3::rotation_between(&Vector3::z(), &axis.into_inner()).unwrap_or_else(|| {
        // axis = -z: half a turn about x
        Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
    })
}

/// `n` points of a Fibonacci spiral, even in area over the cap.
pub fn fibonacci(n: usize, region: &Region) -> Vec<UnitVec> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let r = frame(&region.axis);
    let depth = 1.0 - region.cap.0.cos();
    (0..n)
        .map(|k| {
            let z = 1.0 - depth * (k as f64 + 0.5) / n as f64;
            let s = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * k as f64;
            UnitVec::new_normalize(r * Vector3::new(s * phi.cos(), s * phi.sin(), z))
        })
        .collect()
}

/// The Fibonacci spiral's points pushed apart by an inverse-square repulsion for `rounds`
/// rounds (each step a fraction of the nearest distance), kept in the cap: a Tammes-like
/// packing. Deterministic (a fixed order of sums).
pub fn tammes(n: usize, region: &Region, rounds: usize) -> Vec<UnitVec> {
    let mut pts: Vec<Vector3<f64>> = fibonacci(n, region)
        .iter()
        .map(|p| p.into_inner())
        .collect();
    for round in 0..rounds {
        let step = 0.02 * (1.0 - round as f64 / rounds as f64) + 0.002;
        let forces: Vec<Vector3<f64>> = (0..n)
            .map(|i| {
                let mut f = Vector3::zeros();
                for j in (0..n).filter(|&j| j != i) {
                    let d = pts[i] - pts[j];
                    let len = d.norm().max(1e-9);
                    f += d / (len * len * len);
                }
                // keep the tangential part
                f - pts[i] * f.dot(&pts[i])
            })
            .collect();
        let scale = forces.iter().map(|f| f.norm()).fold(0.0, f64::max);
        if scale <= 0.0 {
            break;
        }
        for (p, f) in pts.iter_mut().zip(&forces) {
            let moved = UnitVec::new_normalize(*p + f * (step / scale));
            *p = region.clamp(&moved).into_inner();
        }
    }
    pts.into_iter().map(UnitVec::new_normalize).collect()
}

/// The `n` vertices of the first solid of `solids` with at least `n` vertices whose `n`
/// nearest the cap's axis (one vertex turned onto it) all lie in the cap.
fn solid_points(solids: &[Vec<Vector3<f64>>], n: usize, region: &Region) -> Option<Vec<UnitVec>> {
    for solid in solids.iter().filter(|s| s.len() >= n) {
        let first = UnitVec::new_normalize(solid[0]);
        let turn = Rotation3::rotation_between(&first.into_inner(), &region.axis.into_inner())
            .unwrap_or_else(|| {
                Rotation3::from_axis_angle(
                    &UnitVec::new_normalize(perpendicular(&first)),
                    std::f64::consts::PI,
                )
            });
        let mut pts: Vec<UnitVec> = solid
            .iter()
            .map(|v| UnitVec::new_normalize(turn * v))
            .collect();
        pts.sort_by(|a, b| b.dot(&region.axis).total_cmp(&a.dot(&region.axis)));
        pts.truncate(n);
        if pts.iter().all(|p| region.contains(p)) {
            return Some(pts);
        }
    }
    None
}

/// Every sign combination of `v`'s non-zero coordinates, and its cyclic permutations.
fn cyclic_signed(v: [f64; 3]) -> Vec<Vector3<f64>> {
    let mut out = Vec::new();
    for shift in 0..3 {
        let c = [v[shift % 3], v[(shift + 1) % 3], v[(shift + 2) % 3]];
        for signs in 0..8u8 {
            let s = |k: usize| if signs >> k & 1 == 1 { -1.0 } else { 1.0 };
            if (0..3).any(|k| c[k] == 0.0 && signs >> k & 1 == 1) {
                continue;
            }
            out.push(Vector3::new(s(0) * c[0], s(1) * c[1], s(2) * c[2]));
        }
    }
    out
}

/// The golden ratio.
const PHI: f64 = 1.618_033_988_749_895;

/// The Platonic solids' vertices: tetrahedron, octahedron, cube, icosahedron, dodecahedron.
fn platonic() -> Vec<Vec<Vector3<f64>>> {
    let cube: Vec<Vector3<f64>> = (0..8u8)
        .map(|s| {
            let c = |k: u8| if s >> k & 1 == 1 { -1.0 } else { 1.0 };
            Vector3::new(c(0), c(1), c(2))
        })
        .collect();
    let tetra = cube
        .iter()
        .filter(|v| v.x * v.y * v.z > 0.0)
        .copied()
        .collect();
    let octa = vec![
        Vector3::x(),
        -Vector3::x(),
        Vector3::y(),
        -Vector3::y(),
        Vector3::z(),
        -Vector3::z(),
    ];
    let icosa = cyclic_signed([0.0, 1.0, PHI]);
    let mut dodeca = cube.clone();
    dodeca.extend(cyclic_signed([0.0, 1.0 / PHI, PHI]));
    vec![tetra, octa, cube, icosa, dodeca]
}

/// Archimedean solids' vertices: cuboctahedron, icosidodecahedron, truncated icosahedron.
fn archimedean() -> Vec<Vec<Vector3<f64>>> {
    let cubocta = cyclic_signed([1.0, 1.0, 0.0]);
    let mut icosidodeca = cyclic_signed([0.0, 0.0, PHI]);
    icosidodeca.extend(cyclic_signed([0.5, PHI / 2.0, PHI * PHI / 2.0]));
    let mut trunc = cyclic_signed([0.0, 1.0, 3.0 * PHI]);
    trunc.extend(cyclic_signed([1.0, 2.0 + PHI, 2.0 * PHI]));
    trunc.extend(cyclic_signed([PHI, 2.0, PHI * PHI * PHI]));
    vec![cubocta, icosidodeca, trunc]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::packing::min_separation;

    fn sphere() -> Region {
        Region {
            axis: UnitVec::new_normalize(Vector3::z()),
            cap: Radians(std::f64::consts::PI),
        }
    }

    #[test]
    fn the_solids_have_their_vertex_counts_and_equal_radii() {
        let counts: Vec<usize> = platonic().iter().map(|s| s.len()).collect();
        assert_eq!(counts, [4, 6, 8, 12, 20]);
        let counts: Vec<usize> = archimedean().iter().map(|s| s.len()).collect();
        assert_eq!(counts, [12, 30, 60]);
        for s in platonic().iter().chain(&archimedean()) {
            let r0 = s[0].norm();
            assert!(s.iter().all(|v| (v.norm() - r0).abs() < 1e-9));
        }
    }

    #[test]
    fn the_icosahedron_is_twelve_points_63_degrees_apart() {
        let p = seed_points(Family::Platonic, 12, &sphere(), &[]).unwrap();
        let sep = min_separation(&p).0.to_degrees();
        assert!((sep - 63.435).abs() < 0.01, "{sep}");
    }

    #[test]
    fn tammes_spreads_points_wider_than_the_spiral_it_starts_from() {
        let cap = Region {
            axis: UnitVec::new_normalize(-Vector3::z()),
            cap: Radians(58.3f64.to_radians()),
        };
        let fib = min_separation(&fibonacci(16, &cap)).0;
        let tam = tammes(16, &cap, 300);
        assert!(tam.iter().all(|p| cap.contains(p)));
        assert!(
            min_separation(&tam).0 > fib * 1.1,
            "{fib} -> {:?}",
            min_separation(&tam)
        );
    }
}
