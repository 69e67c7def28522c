//! From settled equilibria to plans. The entry points are the [`Motor`](commutation::Motor)'s
//! methods (`settle`, `plan`, `plan_waypoints`, `simulate`, `run`), [`planner::plan`] (a
//! [`Plan`](plan::Plan) of [`PlanRow`](plan::PlanRow)s for [`PlanSettings`](plan::PlanSettings)),
//! [`simulate::simulate`] (a plan replayed through the dynamics),
//! [`waypoints::plan_waypoints`] (a motion through waypoints) and [`closed_loop::drive`] (a
//! [`Controller`](closed_loop::Controller) that replans from measured orientations, played
//! against a [`Plant`](closed_loop::Plant)). Beneath them: which coil:magnet pairs to switch
//! ([`commutation`]) or which sets of coils ([`coilsets`]), the searches that chain steps
//! towards a target rotation ([`search`], shared by every step model; [`seek`], straight for a
//! goal orientation), the wells fitted to measured steps ([`identify`]), which pairs of a
//! settled set hold the ball ([`holding`]), how a front end asks for a loop ([`options`]), how
//! long a replay keeps each coil on ([`on_time`], shared with the hardware replay's check) and
//! abandoning a planning from another thread ([`cancel`]); random coil sets to log for a fit
//! ([`excitation`]); the layout optimiser's spec, seed layouts, objectives and evolution
//! ([`design`]).

pub mod cancel;
pub mod closed_loop;
pub mod coilsets;
pub mod commutation;
pub mod design;
pub mod excitation;
pub mod fit;
pub mod fit_parts;
pub mod holding;
pub mod identify;
mod landing;
mod motor;
pub mod on_time;
pub mod options;
pub mod plan;
pub mod planner;
pub mod search;
pub mod seek;
pub mod simulate;
pub mod waypoints;
