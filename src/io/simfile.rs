//! The results of `simulate`: one CSV row per plan step with the simulated orientation, written
//! by `simulate` and read back by `view` (which draws it as a ghost ball).

use crate::error::Result;
use crate::io::table::{write_csv, Table};
use crate::model::geometry::{orientation_from_xyzw, xyzw, Orientation};
use crate::planning::simulate::SimRow;
use std::io::Write;
use std::path::Path;

/// The header `simulate` writes.
pub const HEADER: [&str; 8] = [
    "step",
    "qx",
    "qy",
    "qz",
    "qw",
    "deviation_deg",
    "settled",
    "settle_time_s",
];

/// Columns a simulate results file must have to be read back.
pub const SIM_COLUMNS: [&str; 5] = ["step", "qx", "qy", "qz", "qw"];

/// One row of `simulate` results read back: the simulated orientation after a plan step.
#[derive(Debug, Clone, PartialEq)]
pub struct SimRecord {
    /// The plan step it followed (the file's `step` column).
    pub step: usize,
    /// Where the ball settled (body to world; columns `qx,qy,qz,qw`).
    pub q: Orientation,
    /// The file's `deviation_deg` column, if it has one.
    pub deviation_deg: Option<f64>,
}

/// Writes the replay CSV (columns [`HEADER`]).
pub fn write_sim(rows: &[SimRow], out: &mut dyn Write) -> Result<()> {
    let record = |r: &SimRow| {
        let q = xyzw(&r.q);
        vec![
            r.step.to_string(),
            q[0].to_string(),
            q[1].to_string(),
            q[2].to_string(),
            q[3].to_string(),
            r.deviation_deg.to_string(),
            r.settled.to_string(),
            r.settle_time_s.to_string(),
        ]
    };
    write_csv(out, "<simulate output>", &HEADER, rows.iter().map(record))
}

/// Reads `simulate` results: a CSV whose header includes `step,qx,qy,qz,qw` (other columns are
/// ignored; an optional `deviation_deg` is kept). Errors name the file, line and column.
pub fn read_sim(path: &Path) -> Result<Vec<SimRecord>> {
    let text = crate::io::input::text(path)?;
    parse_sim(&text, path)
}

/// Parses simulate results text (`path` names it in errors).
pub fn parse_sim(text: &str, path: &Path) -> Result<Vec<SimRecord>> {
    let t = Table::parse(text, path)?;
    let idx = SIM_COLUMNS
        .iter()
        .map(|name| t.require(name, " (step,qx,qy,qz,qw)"))
        .collect::<Result<Vec<_>>>()?;
    let dev_col = t.column("deviation_deg");
    let mut rows: Vec<SimRecord> = Vec::new();
    for r in t.rows() {
        let step = r.step(idx[0])?;
        if rows.iter().any(|o| o.step == step) {
            return Err(r.error(format!(
                "column `step`: expected each step once, got step {step} again"
            )));
        }
        let num = |k: usize| r.finite(idx[k], SIM_COLUMNS[k]);
        let q = orientation_from_xyzw(num(1)?, num(2)?, num(3)?, num(4)?)
            .ok_or_else(|| r.error("columns `qx..qw`: expected a non-zero quaternion".into()))?;
        let deviation_deg = match dev_col {
            Some(c) if !r.get(c).is_empty() => Some(r.finite(c, "deviation_deg")?),
            _ => None,
        };
        rows.push(SimRecord {
            step,
            q,
            deviation_deg,
        });
    }
    t.require_rows("simulated step")?;
    Ok(rows)
}
