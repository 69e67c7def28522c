//! The files: scenarios in TOML (`scenario`), plans in CSV (`planfile`), simulate results
//! (`simfile`), closed-loop results (`loopfile`), the scenario's `[sensor]` section
//! (`sensor_section`), the waypoints of a path (`waypoints`), an active set's text (`pairs`), the one CSV reader (`table`), the
//! one way an input file is read, regular and bounded (`input`), and the one place that writes a
//! file whole or not at all (`output`).

pub mod fitfiles;
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
