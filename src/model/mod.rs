//! The motor's geometry: vectors, orientations, angles and indices (`geometry`), the symmetry
//! groups (`symmetry`), the packings of rotor magnets and stator coils (`packing`), and seeded
//! random numbers (`random`).
//! Nothing here knows about forces or time.
//!
//! Entry points: [`Orientation`] (body to world) and [`UnitVec`], the angles [`Degrees`] and
//! [`Radians`] (converted only explicitly), a coil:magnet [`Pair`] of a [`CoilId`] and a
//! [`MagnetId`]; [`geometry::rot_q`] and [`geometry::axis_error`] (a rotation and how far it
//! strays from an axis); a [`Packing`] of points, built from a [`SemiRegular`] (the orbits of a
//! [`Group`]) or [`packing::prototype_rotor`] and [`packing::prototype_stator`], compared by
//! [`packing::report`]; [`SplitMix`], the seeded random numbers.

pub mod geometry;
pub mod packing;
pub mod random;
pub mod symmetry;

pub use geometry::{CoilId, Degrees, MagnetId, Orientation, Pair, Radians, UnitVec};
pub use packing::{Packing, PackingReport, SemiRegular};
pub use random::SplitMix;
pub use symmetry::Group;
