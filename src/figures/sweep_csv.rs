//! Reading what a sweep map shows from a sweep CSV: each scheme's (axis, value) points
//! ([`parse_sweep`], [`parse_sweep_column`]) and the axes not reached ([`parse_unreached`]).

use crate::error::Result;
use crate::figures::figure::normalise;
use crate::io::table::Table;
use std::path::Path;

/// The columns a sweep CSV must have (besides an optional `scheme`).
pub const SWEEP_COLUMNS: [&str; 4] = ["axis_x", "axis_y", "axis_z", "max_axis_error_deg"];

/// One scheme's points of a sweep CSV: (scheme, or None without a `scheme` column; points).
pub type SweepPoints = (Option<String>, Vec<([f64; 3], f64)>);

/// Reads a sweep CSV (columns [`SWEEP_COLUMNS`], optional `scheme`): the points of each scheme
/// in the order the schemes first appear. Values may be NaN ("no result"); axes must be finite
/// and non-zero.
pub fn parse_sweep(text: &str, path: &Path) -> Result<Vec<SweepPoints>> {
    parse_sweep_column(text, path, SWEEP_COLUMNS[3])
}

/// The column of a sweep CSV with the pivot model's floor per axis (see
/// [`crate::planning::commutation::pivot_floor`]).
pub const FLOOR_COLUMN: &str = "pivot_floor_deg";

/// Reads a sweep CSV like [`parse_sweep`], with the values of column `value` in place of
/// `max_axis_error_deg`.
pub fn parse_sweep_column(text: &str, path: &Path, value: &str) -> Result<Vec<SweepPoints>> {
    let t = Table::parse(text, path)?;
    let columns = [SWEEP_COLUMNS[0], SWEEP_COLUMNS[1], SWEEP_COLUMNS[2], value];
    let idx = columns
        .iter()
        .map(|c| t.require(c, ""))
        .collect::<Result<Vec<_>>>()?;
    let scheme_col = t.column("scheme");
    let mut out: Vec<SweepPoints> = Vec::new();
    for r in t.rows() {
        let num = |k: usize| r.number(idx[k], columns[k]);
        let axis = [num(0)?, num(1)?, num(2)?];
        if normalise(&axis).is_none() {
            return Err(r.error(format!(
                "columns `axis_x..axis_z`: expected a finite, non-zero axis, got {axis:?}"
            )));
        }
        let value = num(3)?;
        // An axis error is an angle: anything else (1e308, inf) would also give the colour
        // scale an infinite span, which the tick search never finishes.
        if !(value.is_nan() || (0.0..=180.0 + 1e-9).contains(&value)) {
            return Err(r.error(format!(
                "column `max_axis_error_deg`: expected an angle from 0 to 180 degrees (or NaN: no result), got {}",
                crate::text::shown(value)
            )));
        }
        let scheme = scheme_col.map(|k| r.get(k).to_string());
        match out.iter_mut().find(|(s, _)| *s == scheme) {
            Some((_, pts)) => pts.push((axis, value)),
            None => out.push((scheme, vec![(axis, value)])),
        }
    }
    t.require_rows("sweep")?;
    Ok(out)
}

/// The axes of a sweep CSV's cases that did not reach their target (column `reached` is
/// `false`), with their scheme (or None without a `scheme` column); none without `reached`.
pub fn parse_unreached(text: &str, path: &Path) -> Result<Vec<(Option<String>, [f64; 3])>> {
    let t = Table::parse(text, path)?;
    let (Some(reached), Some(x), Some(y), Some(z)) = (
        t.column("reached"),
        t.column("axis_x"),
        t.column("axis_y"),
        t.column("axis_z"),
    ) else {
        return Ok(Vec::new());
    };
    let scheme = t.column("scheme");
    let mut out = Vec::new();
    for r in t.rows().filter(|r| r.get(reached) == "false") {
        let num = |k: usize| r.get(k).parse::<f64>().ok();
        if let (Some(a), Some(b), Some(c)) = (num(x), num(y), num(z)) {
            out.push((scheme.map(|k| r.get(k).to_string()), [a, b, c]));
        }
    }
    Ok(out)
}
