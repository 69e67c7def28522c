//! Helpers shared by the integration tests.
#![allow(dead_code)]

use nalgebra::UnitQuaternion;
use spherestep::geometry::{angular_distance, MagnetId, Orientation, UnitVec};
use spherestep::scenario::Scenario;

/// The magnet nearest to coil `coil` at orientation `q`, and its distance.
pub fn nearest_magnet(sc: &Scenario, coil: usize, q: &Orientation) -> (MagnetId, f64) {
    let s = sc.stator.points[coil];
    sc.rotor
        .points
        .iter()
        .enumerate()
        .map(|(j, r)| {
            let p = UnitVec::new_normalize(q * r.into_inner());
            (MagnetId(j), angular_distance(&p, &s).0)
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .expect("a rotor has magnets")
}

pub fn identity() -> Orientation {
    UnitQuaternion::identity()
}

/// Path of the built binary.
pub fn bin() -> std::path::PathBuf {
    std::path::PathBuf::from(env!("CARGO_BIN_EXE_spherestep"))
}
