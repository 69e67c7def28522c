//! The layout optimiser's library half (`spherestep design`, issue 56): what a scenario's
//! `[design]` section asks for ([`DesignSpec`]: which packing is free, how many coils and
//! magnets, the cap the coils stay in, the separations, the seed families, the axes and the
//! search's size), the seed layouts ([`families`]), a layout decoded from the search's genes
//! and checked against the separations ([`layout`]), and the objectives of a layout from its
//! sweep's per-axis results ([`objectives`]). With the `design` feature, [`search`] holds the
//! NSGA-II generation step built from the `moors` crate's operators; the command layer owns
//! the runs (each generation a batch folder).

pub mod families;
pub mod layout;
pub mod objectives;
#[cfg(feature = "design")]
pub mod search;

use crate::model::geometry::{Radians, UnitVec};

/// Which packing the search may change.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Free {
    /// The stator's coils (world frame, within the cap); the rotor stays as the scenario has it.
    Stator,
    /// The rotor's magnets (body frame, the whole sphere); the stator stays.
    Rotor,
    /// Both.
    Both,
}

impl Free {
    /// Whether the stator's coils are free.
    pub fn stator(self) -> bool {
        matches!(self, Free::Stator | Free::Both)
    }
    /// Whether the rotor's magnets are free.
    pub fn rotor(self) -> bool {
        matches!(self, Free::Rotor | Free::Both)
    }
    /// The name as a scenario writes it.
    pub fn name(self) -> &'static str {
        match self {
            Free::Stator => "stator",
            Free::Rotor => "rotor",
            Free::Both => "both",
        }
    }
}

/// A family the search's first layouts are drawn from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Family {
    /// The scenario's own packing (where its count is the one asked for).
    Scenario,
    /// The vertices of a Platonic solid (4, 6, 8, 12 or 20), nearest the cap's axis first.
    Platonic,
    /// The vertices of an Archimedean solid (cuboctahedron 12, icosidodecahedron 30, truncated
    /// icosahedron 60), nearest the cap's axis first.
    Archimedean,
    /// A Fibonacci spiral of the count, even in area over the cap (or the sphere).
    Fibonacci,
    /// The count repelled apart within the cap (or over the sphere), a Tammes-like packing.
    Tammes,
}

impl Family {
    /// Every family, in the order genes select them.
    pub const ALL: [Family; 5] = [
        Family::Scenario,
        Family::Platonic,
        Family::Archimedean,
        Family::Fibonacci,
        Family::Tammes,
    ];
    /// The name as a scenario writes it.
    pub fn name(self) -> &'static str {
        match self {
            Family::Scenario => "scenario",
            Family::Platonic => "platonic",
            Family::Archimedean => "archimedean",
            Family::Fibonacci => "fibonacci",
            Family::Tammes => "tammes",
        }
    }
    /// The family a name denotes.
    pub fn parse(name: &str) -> Option<Family> {
        Family::ALL.into_iter().find(|f| f.name() == name)
    }
}

/// A scenario's `[design]` section, checked (docs/scenario-format.md lists its keys).
#[derive(Debug, Clone, PartialEq)]
pub struct DesignSpec {
    /// Which packing the search may change.
    pub free: Free,
    /// The coil counts allowed, `min..=max` (one count when equal).
    pub coils: (usize, usize),
    /// The magnet counts allowed, `min..=max`.
    pub magnets: (usize, usize),
    /// The axis of the cap the coils stay in (world frame).
    pub cap_axis: UnitVec,
    /// The cap's half-angle.
    pub cap: Radians,
    /// No two coils closer than this (their centres, the coil's diameter as an angle).
    pub coil_separation: Radians,
    /// No two magnets closer than this.
    pub magnet_separation: Radians,
    /// The families the first generation is seeded from, in the order given.
    pub families: Vec<Family>,
    /// The coarse axes every layout is planned about.
    pub axes: usize,
    /// The full axes the promising layouts are planned about (the coarse ones first).
    pub full_axes: usize,
    /// The seed the axes are drawn from (uniform over the sphere).
    pub axis_seed: u64,
    /// Layouts per generation.
    pub population: usize,
    /// Generations after the first.
    pub generations: usize,
    /// The angle every axis is turned by.
    pub angle: Radians,
    /// The bound of the whole packing's rotation (each of its three components).
    pub rotation: Radians,
    /// The bound of each point's move along each of its two tangent directions.
    pub point_move: Radians,
}

impl DesignSpec {
    /// The axes a layout is planned about: the first `count` of the stream drawn from
    /// `axis_seed` (so the coarse axes are the first of the full ones).
    pub fn axes_of(&self, count: usize) -> Vec<UnitVec> {
        let mut r = crate::model::random::SplitMix::new(self.axis_seed);
        (0..count).map(|_| r.direction()).collect()
    }
}

/// The most coils (or magnets) that may fit at angular separation `sep` in a cap of half-angle
/// `cap` (the whole sphere at 180 degrees): each point owns a disc of radius `sep / 2` and
/// the discs lie in the cap grown by `sep / 2`, so their areas bound the count. A necessary
/// condition: a count above it can never be placed.
pub fn area_bound(cap: Radians, sep: Radians) -> usize {
    let grown = (cap.0 + sep.0 / 2.0).min(std::f64::consts::PI);
    let disc = 1.0 - (sep.0 / 2.0).cos();
    if disc <= 0.0 {
        return usize::MAX;
    }
    ((1.0 - grown.cos()) / disc).floor() as usize
}
