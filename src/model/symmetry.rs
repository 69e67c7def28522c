//! The finite rotation groups of the Platonic solids, T (12), O (24) and I (60), and the orbit
//! of a generator point under a group: the raw material of semi-regular packings.

use crate::model::geometry::{rot, unit, Radians, UnitVec};
use nalgebra::{Rotation3, Vector3};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// A finite rotation group of the sphere.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Group {
    /// Tetrahedral, 12 rotations.
    T,
    /// Octahedral, 24 rotations.
    O,
    /// Icosahedral, 60 rotations (a 5-fold axis along Z).
    I,
}

impl Group {
    /// Number of rotations in the group.
    pub fn order(self) -> usize {
        match self {
            Group::T => 12,
            Group::O => 24,
            Group::I => 60,
        }
    }

    /// All rotations of the group, in a fixed, deterministic order (the identity first).
    pub fn elements(self) -> Vec<Rotation3<f64>> {
        let ax = |x: f64, y: f64, z: f64| unit(Vector3::new(x, y, z)).expect("constant axis");
        let gens = match self {
            Group::T => vec![
                rot(&ax(0.0, 0.0, 1.0), Radians(PI)),
                rot(&ax(1.0, 1.0, 1.0), Radians(2.0 * PI / 3.0)),
            ],
            Group::O => vec![
                rot(&ax(0.0, 0.0, 1.0), Radians(PI / 2.0)),
                rot(&ax(1.0, 0.0, 0.0), Radians(PI / 2.0)),
            ],
            Group::I => {
                // Icosahedron with vertices at +-Z: a 5-fold axis on Z and a 5-fold axis at the
                // polar angle atan(2) (a neighbouring vertex), in the X-Z plane.
                let t = 2.0f64.atan();
                vec![
                    rot(&ax(0.0, 0.0, 1.0), Radians(2.0 * PI / 5.0)),
                    rot(&ax(t.sin(), 0.0, t.cos()), Radians(2.0 * PI / 5.0)),
                ]
            }
        };
        let mut elems = vec![Rotation3::identity()];
        let mut i = 0;
        while i < elems.len() {
            let e = elems[i];
            for g in &gens {
                let c = g * e;
                if !elems
                    .iter()
                    .any(|x| (x.matrix() - c.matrix()).norm() < 1e-9)
                {
                    elems.push(c);
                }
            }
            i += 1;
        }
        debug_assert_eq!(elems.len(), self.order());
        elems
    }
}

/// The orbit of `p` under `group`: distinct images, in the group's element order.
pub fn orbit(group: Group, p: &UnitVec) -> Vec<UnitVec> {
    let mut out: Vec<UnitVec> = Vec::new();
    for g in group.elements() {
        let q = UnitVec::new_normalize(g * p.into_inner());
        if !out
            .iter()
            .any(|x| (x.into_inner() - q.into_inner()).norm() < 1e-9)
        {
            out.push(q);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_have_their_orders_and_are_closed() {
        for g in [Group::T, Group::O, Group::I] {
            let e = g.elements();
            assert_eq!(e.len(), g.order());
            for a in &e {
                for b in &e {
                    let c = a * b;
                    assert!(e.iter().any(|x| (x.matrix() - c.matrix()).norm() < 1e-9));
                }
            }
        }
    }

    #[test]
    fn orbits_of_special_points() {
        let z = unit(Vector3::new(0.0, 0.0, 1.0)).unwrap();
        assert_eq!(orbit(Group::O, &z).len(), 6);
        assert_eq!(orbit(Group::I, &z).len(), 12);
        let c = unit(Vector3::new(1.0, 1.0, 1.0)).unwrap();
        assert_eq!(orbit(Group::O, &c).len(), 8);
        let g = unit(Vector3::new(0.3, 0.1, 0.9)).unwrap();
        assert_eq!(orbit(Group::O, &g).len(), 24);
        assert_eq!(orbit(Group::I, &g).len(), 60);
        assert_eq!(orbit(Group::T, &g).len(), 12);
    }
}
