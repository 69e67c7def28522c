//! A layout from the search's genes, and back: the genes are numbers in fixed bounds (the
//! family and the counts as selectors in [0, 1], the rotations and per-point moves in
//! [-1, 1], scaled by the spec's bounds), decoded into the stator's coils and the rotor's
//! magnets and checked against the separations. A layout that breaks them is kept with its
//! shortfall (`violation_deg`), which the search counts against it instead of planning it.

use super::families::{perpendicular, seed_points, Region};
use super::{DesignSpec, Family};
use crate::model::geometry::{Radians, UnitVec};
use crate::model::packing::{min_separation, Packing};
use nalgebra::{Rotation3, Vector3};

/// Genes before the per-point moves: family, coil count, magnet count, the stator's rotation
/// (3), the rotor's rotation (3).
pub const HEAD_GENES: usize = 9;

/// A decoded layout.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// The family its points were seeded from (the stator's when it is free, else the rotor's).
    pub family: Family,
    /// The coils (world frame).
    pub stator: Vec<UnitVec>,
    /// The magnets (body frame).
    pub rotor: Vec<UnitVec>,
    /// How far, degrees, the closest coils and magnets fall short of their separations (0: none).
    pub violation_deg: f64,
}

/// How many genes a layout of `spec` has.
pub fn gene_count(spec: &DesignSpec) -> usize {
    let mut n = HEAD_GENES;
    if spec.free.stator() {
        n += 2 * spec.coils.1;
    }
    if spec.free.rotor() {
        n += 2 * spec.magnets.1;
    }
    n
}

/// Each gene's bounds (the selectors [0, 1], the rest [-1, 1]).
pub fn gene_bounds(spec: &DesignSpec) -> Vec<(f64, f64)> {
    (0..gene_count(spec))
        .map(|k| if k < 3 { (0.0, 1.0) } else { (-1.0, 1.0) })
        .collect()
}

/// Which of `count` choices a selector gene in [0, 1] picks.
fn pick(gene: f64, count: usize) -> usize {
    ((gene.clamp(0.0, 1.0) * count as f64) as usize).min(count.saturating_sub(1))
}

/// The selector gene that picks choice `k` of `count` (its middle).
fn selector(k: usize, count: usize) -> f64 {
    (k as f64 + 0.5) / count.max(1) as f64
}

/// The genes of the unmoved, unturned seed layout of `families[k]`, with the counts nearest
/// the scenario's own (`own_coils`, `own_magnets`) in the spec's ranges.
pub fn seed_genes(spec: &DesignSpec, k: usize, own_coils: usize, own_magnets: usize) -> Vec<f64> {
    let mut g = vec![0.0; gene_count(spec)];
    g[0] = selector(k, spec.families.len());
    let (c0, c1) = spec.coils;
    g[1] = selector(own_coils.clamp(c0, c1) - c0, c1 - c0 + 1);
    let (m0, m1) = spec.magnets;
    g[2] = selector(own_magnets.clamp(m0, m1) - m0, m1 - m0 + 1);
    g
}

/// The first generation's seeds: every family's unmoved, unturned layout ([`seed_genes`]) at
/// every coil count of the spec's range when the stator is free (the count nearest the
/// scenario's first, then outwards, the smaller first at equal distance; a fixed stator keeps
/// its own), with the magnet count nearest the scenario's; families inner. A seed whose layout
/// an earlier seed already is (a family without that count falls back to the Tammes packing)
/// is left out, so no layout is planned twice; at most `spec.population` seeds.
pub fn seeds(spec: &DesignSpec, own: Own) -> Vec<Vec<f64>> {
    let (c0, c1) = spec.coils;
    let nearest = own.stator.len().clamp(c0, c1);
    let mut counts: Vec<usize> = if spec.free.stator() {
        (c0..=c1).collect()
    } else {
        vec![nearest]
    };
    counts.sort_by_key(|&c| (c.abs_diff(nearest), c));
    let mut out: Vec<Vec<f64>> = Vec::new();
    let mut seen: Vec<Layout> = Vec::new();
    for c in counts {
        for k in 0..spec.families.len() {
            if out.len() >= spec.population {
                return out;
            }
            let g = seed_genes(spec, k, c, own.rotor.len());
            let l = decode(spec, &g, own);
            if seen
                .iter()
                .any(|s| s.stator == l.stator && s.rotor == l.rotor)
            {
                continue;
            }
            seen.push(l);
            out.push(g);
        }
    }
    out
}

/// The scenario's packings, as the layout starts from when they are not free.
#[derive(Debug, Clone, Copy)]
pub struct Own<'a> {
    /// The scenario's coils.
    pub stator: &'a [UnitVec],
    /// The scenario's magnets.
    pub rotor: &'a [UnitVec],
}

impl<'a> Own<'a> {
    /// The points of a scenario's `stator` and `rotor`.
    pub fn of(stator: &'a Packing, rotor: &'a Packing) -> Own<'a> {
        Own {
            stator: &stator.points,
            rotor: &rotor.points,
        }
    }
}

/// The layout the genes denote.
pub fn decode(spec: &DesignSpec, genes: &[f64], own: Own) -> Layout {
    let family = spec.families[pick(genes[0], spec.families.len())];
    let (c0, c1) = spec.coils;
    let coils = c0 + pick(genes[1], c1 - c0 + 1);
    let (m0, m1) = spec.magnets;
    let magnets = m0 + pick(genes[2], m1 - m0 + 1);
    let cap = Region {
        axis: spec.cap_axis,
        cap: spec.cap,
    };
    let sphere = Region {
        axis: spec.cap_axis,
        cap: Radians(std::f64::consts::PI),
    };
    let mut moves = &genes[HEAD_GENES.min(genes.len())..];
    let mut used = family;
    let stator = if spec.free.stator() {
        let (pts, f) = seeded(family, coils, &cap, own.stator);
        used = f;
        let (mine, rest) = moves.split_at((2 * c1).min(moves.len()));
        moves = rest;
        shaped(pts, &genes[3..6], mine, spec, &cap)
    } else {
        own.stator.to_vec()
    };
    let rotor = if spec.free.rotor() {
        let (pts, f) = seeded(family, magnets, &sphere, own.rotor);
        if !spec.free.stator() {
            used = f;
        }
        shaped(pts, &genes[6..9], moves, spec, &sphere)
    } else {
        own.rotor.to_vec()
    };
    let short =
        |pts: &[UnitVec], sep: Radians| (sep.0 - min_separation(pts).0).max(0.0).to_degrees();
    let violation_deg =
        short(&stator, spec.coil_separation) + short(&rotor, spec.magnet_separation);
    Layout {
        family: used,
        stator,
        rotor,
        violation_deg,
    }
}

/// `n` points of `family` in `region`, or of the Tammes packing where the family has none.
fn seeded(family: Family, n: usize, region: &Region, own: &[UnitVec]) -> (Vec<UnitVec>, Family) {
    match seed_points(family, n, region, own) {
        Some(p) => (p, family),
        None => (super::families::tammes(n, region, 300), Family::Tammes),
    }
}

/// The points turned by the rotation genes (a rotation vector, each component scaled by the
/// spec's `rotation`), each moved by its two tangent genes (scaled by `point_move`), kept in
/// `region`.
fn shaped(
    pts: Vec<UnitVec>,
    turn: &[f64],
    moves: &[f64],
    spec: &DesignSpec,
    region: &Region,
) -> Vec<UnitVec> {
    let r = spec.rotation.0;
    let rot = Rotation3::new(Vector3::new(turn[0] * r, turn[1] * r, turn[2] * r));
    pts.iter()
        .enumerate()
        .map(|(i, p)| {
            let mut q = rot * p.into_inner();
            if let Some(m) = moves.get(2 * i..2 * i + 2) {
                let u = UnitVec::new_normalize(q);
                let e1 = perpendicular(&u);
                let e2 = u.cross(&e1);
                let (a, b) = (m[0] * spec.point_move.0, m[1] * spec.point_move.0);
                q = u.into_inner() + e1 * a.tan() + e2 * b.tan();
            }
            region.clamp(&UnitVec::new_normalize(q))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::packing::{prototype_rotor, prototype_stator};
    use crate::planning::design::Free;

    pub(crate) fn spec() -> DesignSpec {
        DesignSpec {
            free: Free::Stator,
            coils: (12, 16),
            magnets: (80, 80),
            cap_axis: UnitVec::new_normalize(-Vector3::z()),
            cap: Radians(79.2f64.to_radians()),
            coil_separation: Radians(10f64.to_radians()),
            magnet_separation: Radians(5f64.to_radians()),
            families: vec![Family::Scenario, Family::Fibonacci, Family::Tammes],
            axes: 4,
            full_axes: 8,
            axis_seed: 1,
            population: 4,
            generations: 1,
            angle: Radians(90f64.to_radians()),
            rotation: Radians(10f64.to_radians()),
            point_move: Radians(3f64.to_radians()),
        }
    }

    #[test]
    fn the_scenario_seed_decodes_to_the_scenario_itself() {
        let (s, r) = (prototype_stator(), prototype_rotor());
        let own = Own::of(&s, &r);
        let sp = spec();
        let l = decode(&sp, &seed_genes(&sp, 0, 16, 80), own);
        assert_eq!(l.family, Family::Scenario);
        assert_eq!(l.stator, s.points);
        assert_eq!(l.rotor, r.points);
        // 12 coils: the prototype has 16, so the family falls back to the Tammes packing
        let mut g = seed_genes(&sp, 0, 12, 80);
        g[3] = 1.0;
        let l = decode(&sp, &g, own);
        assert_eq!((l.family, l.stator.len()), (Family::Tammes, 12));
        let cap = Region {
            axis: sp.cap_axis,
            cap: sp.cap,
        };
        assert!(l.stator.iter().all(|p| cap.contains(p)));
    }

    #[test]
    fn seeds_cover_every_coil_count_nearest_first_and_never_repeat_a_layout() {
        let (s, r) = (prototype_stator(), prototype_rotor());
        let own = Own::of(&s, &r);
        let mut sp = spec();
        sp.families = vec![
            Family::Scenario,
            Family::Platonic,
            Family::Fibonacci,
            Family::Tammes,
        ];
        sp.population = 40;
        let layouts: Vec<Layout> = seeds(&sp, own)
            .iter()
            .map(|g| decode(&sp, g, own))
            .collect();
        let counts: Vec<(usize, Family)> =
            layouts.iter().map(|l| (l.stator.len(), l.family)).collect();
        // 16 (the prototype's own, nearest) first, then 15, 14, 13, 12: the scenario family has
        // only 16, the Platonic solids none in this cap (an icosahedron spans the sphere), so
        // they fall back to the Tammes packing, and the Tammes family's own seed is then the
        // same layout, left out
        let expected = [16, 15, 14, 13, 12]
            .into_iter()
            .flat_map(|c| {
                let mut f = if c == 16 {
                    vec![Family::Scenario]
                } else {
                    vec![]
                };
                f.extend([Family::Tammes, Family::Fibonacci]);
                f.into_iter().map(move |f| (c, f))
            })
            .collect::<Vec<_>>();
        assert_eq!(counts, expected);
        for (i, a) in layouts.iter().enumerate() {
            for b in &layouts[..i] {
                assert!(a.stator != b.stator || a.rotor != b.rotor);
            }
        }
        assert_eq!(layouts[0].stator, s.points);
        // the population caps the seeds, nearest counts kept
        sp.population = 4;
        let few: Vec<usize> = seeds(&sp, own)
            .iter()
            .map(|g| decode(&sp, g, own).stator.len())
            .collect();
        assert_eq!(few, vec![16, 16, 16, 15]);
    }

    #[test]
    fn points_pushed_together_break_the_separation_by_what_they_lack() {
        let (s, r) = (prototype_stator(), prototype_rotor());
        let own = Own::of(&s, &r);
        let mut sp = spec();
        sp.coil_separation = Radians(40f64.to_radians());
        let l = decode(&sp, &seed_genes(&sp, 0, 16, 80), own);
        let lack = 40.0 - min_separation(&s.points).0.to_degrees();
        assert!((l.violation_deg - lack).abs() < 1e-9, "{}", l.violation_deg);
    }
}
