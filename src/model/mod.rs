//! The motor's geometry: vectors, orientations, angles and indices (`geometry`), the symmetry
//! groups (`symmetry`), the packings of rotor magnets and stator coils (`packing`), and seeded
//! random numbers (`random`).
//! Nothing here knows about forces or time.

pub mod geometry;
pub mod packing;
pub mod random;
pub mod symmetry;
