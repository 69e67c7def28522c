//! The files: scenarios in TOML (`scenario`), plans in CSV (`planfile`), simulate results
//! (`simfile`), closed-loop results (`loopfile`), the scenario's `[sensor]` section
//! (`sensor_section`), the waypoints of a path (`waypoints`), an active set's text (`pairs`),
//! the one CSV reader (`table`), the one way an input file is read, regular and bounded
//! (`input`), and the one place that writes a file whole or not at all (`output`).
//!
//! Entry points: [`Scenario`] ([`Scenario::load`], [`Scenario::prototype`],
//! [`Scenario::motor`]; a front end's [`PlanChanges`] through [`Scenario::plan_with`], a plan's
//! rows from a [`PlanInput`] through [`Scenario::checked_rows`]), its [`Sweep`] of
//! [`Motion`]s and its [`SensorSettings`]; [`read_plan`] and [`write_plan`], [`read_sim`] and
//! [`write_sim`], [`write_loop`], [`read_waypoints`]; [`parse_pairs`] (`"0:14,12:26"`);
//! [`input::text`], the checked read of an input file, and [`write_atomic`], a file written
//! whole or not at all.

pub mod fitfiles;
pub mod fitting;
pub mod input;
pub mod loopfile;
pub mod output;
pub mod pairs;
pub mod planfile;
pub mod scenario;
pub mod sensor_section;
pub mod simfile;
pub mod table;
pub mod waypoints;

pub use loopfile::write_loop;
pub use output::write_atomic;
pub use pairs::parse_pairs;
pub use planfile::{read_plan, write_plan};
pub use scenario::{ChangeNames, Motion, PlanChanges, PlanInput, Scenario, Sweep};
pub use sensor_section::SensorSettings;
pub use simfile::{read_sim, write_sim, SimRecord};
pub use waypoints::read_waypoints;
