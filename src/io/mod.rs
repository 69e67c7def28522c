//! The files: scenarios in TOML (`scenario`), plans in CSV (`planfile`), simulate results
//! (`simfile`), the one CSV reader (`table`) and the one place that writes a file whole or not
//! at all (`output`).

pub mod output;
pub mod planfile;
pub mod scenario;
pub mod simfile;
pub mod table;
