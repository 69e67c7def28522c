//! The plan file: one CSV row per commutation step, written by `plan` and read by `simulate`,
//! `replay` and `view`. Columns:
//! `step, pivot_coil, pivot_magnet, new_coil, new_magnet, active, qx, qy, qz, qw,
//!  step_angle_deg, step_axis_error_deg, cum_angle_deg, cum_axis_error_deg, settle_time_s`.
//! Step 0 is the initial commutation state (no pivot; its pairs are the "new" ones). `active`
//! (pairs `coil:magnet` joined by `;`) is what is energised after the step and is authoritative;
//! `new_coil`/`new_magnet` list the newly energised pairs, joined by `;` when there are several.

use crate::error::{Error, Result};
use crate::model::geometry::{orientation_from_xyzw, parse_pairs, xyzw, Pair};
pub use crate::planning::plan::PlanRow;
use std::io::Write;
use std::path::Path;

/// The plan CSV header, in column order.
pub const HEADER: [&str; 15] = [
    "step",
    "pivot_coil",
    "pivot_magnet",
    "new_coil",
    "new_magnet",
    "active",
    "qx",
    "qy",
    "qz",
    "qw",
    "step_angle_deg",
    "step_axis_error_deg",
    "cum_angle_deg",
    "cum_axis_error_deg",
    "settle_time_s",
];

fn join(v: impl Iterator<Item = String>) -> String {
    v.collect::<Vec<_>>().join(";")
}

/// Writes a plan as CSV (header, then one row per step). Numbers use Rust's shortest
/// round-trip formatting, so the same plan gives the same bytes.
pub fn write_plan(rows: &[PlanRow], out: &mut dyn Write) -> Result<()> {
    let e = |e: csv::Error| Error::io("<plan output>", std::io::Error::other(e.to_string()));
    let mut w = csv::Writer::from_writer(out);
    w.write_record(HEADER).map_err(e)?;
    for r in rows {
        let q = xyzw(&r.q);
        w.write_record([
            r.step.to_string(),
            r.pivot.map(|p| p.coil.to_string()).unwrap_or_default(),
            r.pivot.map(|p| p.magnet.to_string()).unwrap_or_default(),
            join(r.new.iter().map(|p| p.coil.to_string())),
            join(r.new.iter().map(|p| p.magnet.to_string())),
            join(r.active.iter().map(|p| p.to_string())),
            q[0].to_string(),
            q[1].to_string(),
            q[2].to_string(),
            q[3].to_string(),
            r.step_angle_deg.to_string(),
            r.step_axis_error_deg.to_string(),
            r.cum_angle_deg.to_string(),
            r.cum_axis_error_deg.to_string(),
            r.settle_time_s.to_string(),
        ])
        .map_err(e)?;
    }
    w.flush().map_err(|er| Error::io("<plan output>", er))?;
    Ok(())
}

/// Reads a plan CSV; any malformed row gives an error naming the file, line and column.
pub fn read_plan(path: &Path) -> Result<Vec<PlanRow>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    parse_plan(&text, path)
}

/// An error in line `line` of the CSV file `path`.
pub fn row_error(path: &Path, line: usize, message: String) -> Error {
    Error::Row {
        file: path.to_path_buf(),
        line,
        message,
    }
}

/// Opens CSV text with a header row (fields trimmed) for one of our readers (plans, sweeps,
/// simulate results): the reader and the header, or an error naming the file.
pub fn csv_reader<'t>(
    text: &'t str,
    path: &Path,
) -> Result<(csv::Reader<&'t [u8]>, csv::StringRecord)> {
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let headers = rdr
        .headers()
        .map_err(|e| row_error(path, 1, format!("unreadable header: {e}")))?
        .clone();
    Ok((rdr, headers))
}

/// Parses plan CSV text (`path` names it in errors).
pub fn parse_plan(text: &str, path: &Path) -> Result<Vec<PlanRow>> {
    let row_err = |line: usize, message: String| row_error(path, line, message);
    let (mut rdr, headers) = csv_reader(text, path)?;
    let col = |name: &str| -> Result<usize> {
        headers
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| row_err(1, format!("expected a column `{name}` in the header")))
    };
    let idx: Vec<usize> = HEADER.iter().map(|h| col(h)).collect::<Result<_>>()?;
    let mut rows = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| {
            let line = e.position().map(|p| p.line() as usize).unwrap_or(0);
            row_err(line, format!("malformed CSV row: {e}"))
        })?;
        let line = rec.position().map(|p| p.line() as usize).unwrap_or(0);
        let get = |k: usize| rec.get(idx[k]).unwrap_or("");
        let num = |k: usize| -> Result<f64> {
            let s = get(k);
            s.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    row_err(
                        line,
                        format!(
                            "column `{}`: expected a finite number, got '{s}'",
                            HEADER[k]
                        ),
                    )
                })
        };
        let step = get(0).parse::<usize>().map_err(|_| {
            row_err(
                line,
                format!(
                    "column `step`: expected a step number (0, 1, ...), got '{}'",
                    get(0)
                ),
            )
        })?;
        let pivot = match (get(1), get(2)) {
            ("", "") => None,
            (c, m) => Some(
                parse_pairs(&format!("{c}:{m}"), "pivot")
                    .map_err(|_| {
                        row_err(
                            line,
                            format!(
                                "columns `pivot_coil`, `pivot_magnet`: expected two indices or both empty, got '{c}', '{m}'"
                            ),
                        )
                    })?[0],
            ),
        };
        let list = |k: usize| -> Result<Vec<usize>> {
            let s = get(k);
            if s.is_empty() {
                return Ok(Vec::new());
            }
            s.split(';')
                .map(|x| x.trim().parse::<usize>())
                .collect::<std::result::Result<_, _>>()
                .map_err(|_| {
                    row_err(
                        line,
                        format!(
                            "column `{}`: expected indices joined by ';', got '{s}'",
                            HEADER[k]
                        ),
                    )
                })
        };
        let (nc, nm) = (list(3)?, list(4)?);
        if nc.len() != nm.len() {
            return Err(row_err(
                line,
                "columns `new_coil`, `new_magnet`: expected as many coils as magnets".into(),
            ));
        }
        let new = nc
            .into_iter()
            .zip(nm)
            .map(|(c, m)| Pair::new(c, m))
            .collect();
        let active = parse_pairs(get(5), "active").map_err(|_| {
            row_err(
                line,
                format!(
                    "column `active`: expected pairs coil:magnet joined by ';', got '{}'",
                    get(5)
                ),
            )
        })?;
        for (k, p) in active.iter().enumerate() {
            if active[..k].iter().any(|o| o.coil == p.coil) {
                return Err(row_err(
                    line,
                    format!(
                        "column `active`: expected each coil once, got coil {} twice",
                        p.coil
                    ),
                ));
            }
        }
        let q = orientation_from_xyzw(num(6)?, num(7)?, num(8)?, num(9)?).ok_or_else(|| {
            row_err(
                line,
                "columns `qx..qw`: expected a non-zero quaternion".into(),
            )
        })?;
        if rows.is_empty() && step != 0 {
            return Err(row_err(
                line,
                format!(
                    "column `step`: expected the first row to be step 0 (the initial commutation state), got {step}"
                ),
            ));
        }
        let settle_time_s = num(14)?;
        if settle_time_s < 0.0 {
            return Err(row_err(
                line,
                format!("column `settle_time_s`: expected a time >= 0 s, got {settle_time_s}"),
            ));
        }
        rows.push(PlanRow {
            step,
            pivot,
            new,
            active,
            q,
            step_angle_deg: num(10)?,
            step_axis_error_deg: num(11)?,
            cum_angle_deg: num(12)?,
            cum_axis_error_deg: num(13)?,
            settle_time_s,
        });
        if let Some(prev) = rows.len().checked_sub(2).map(|i| rows[i].step) {
            if step != prev + 1 {
                return Err(row_err(
                    line,
                    format!(
                        "column `step`: expected {} after step {prev}, got {step}",
                        prev + 1
                    ),
                ));
            }
        }
    }
    if rows.is_empty() {
        return Err(row_err(2, "expected at least one step row".into()));
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{UnitQuaternion, Vector3};

    fn sample() -> Vec<PlanRow> {
        vec![
            PlanRow {
                step: 0,
                pivot: None,
                new: vec![Pair::new(0, 34), Pair::new(14, 9)],
                active: vec![Pair::new(0, 34), Pair::new(14, 9)],
                q: UnitQuaternion::identity(),
                step_angle_deg: 0.0,
                step_axis_error_deg: 0.0,
                cum_angle_deg: 0.0,
                cum_axis_error_deg: 0.0,
                settle_time_s: 0.12,
            },
            PlanRow {
                step: 1,
                pivot: Some(Pair::new(0, 34)),
                new: vec![Pair::new(3, 7)],
                active: vec![Pair::new(0, 34), Pair::new(3, 7)],
                q: UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.0, 0.2)),
                step_angle_deg: 11.459,
                step_axis_error_deg: 0.5,
                cum_angle_deg: 11.459,
                cum_axis_error_deg: 0.5,
                settle_time_s: 0.2,
            },
        ]
    }

    #[test]
    fn round_trip_exact() {
        let rows = sample();
        let mut buf = Vec::new();
        write_plan(&rows, &mut buf).unwrap();
        let text = String::from_utf8(buf).unwrap();
        assert!(text.starts_with("step,pivot_coil,pivot_magnet,new_coil,new_magnet,active,qx,"));
        assert!(text.contains("\n0,,,0;14,34;9,0:34;14:9,"));
        let back = parse_plan(&text, Path::new("p.csv")).unwrap();
        assert_eq!(back.len(), 2);
        assert_eq!(back[1].pivot, Some(Pair::new(0, 34)));
        assert_eq!(back[1].active, rows[1].active);
        assert!((back[1].q.angle_to(&rows[1].q)) < 1e-15);
        assert_eq!(back[1].step_angle_deg, 11.459);
    }

    #[test]
    fn bad_rows_name_line_and_column() {
        let mut buf = Vec::new();
        write_plan(&sample(), &mut buf).unwrap();
        let text = String::from_utf8(buf).unwrap();
        let broken = text.replace("0:34;3:7", "0:34;x:7");
        let e = parse_plan(&broken, Path::new("p.csv"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("p.csv: line 3") && e.contains("`active`"), "{e}");
        let broken = text.replacen("0.12", "abc", 1);
        let e = parse_plan(&broken, Path::new("p.csv"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2") && e.contains("settle_time_s"), "{e}");
        let e = parse_plan("step,qx\n", Path::new("p.csv"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("pivot_coil"), "{e}");
    }
}
