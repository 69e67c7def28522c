//! The plan file: one CSV row per commutation step, written by `plan` and read by `simulate`,
//! `replay` and `view`. Columns:
//! `step, pivot_coil, pivot_magnet, new_coil, new_magnet, active, qx, qy, qz, qw,
//!  step_angle_deg, step_axis_error_deg, cum_angle_deg, cum_axis_error_deg, settle_time_s,
//!  settled`.
//! Step 0 is the initial commutation state (no pivot; its pairs are the "new" ones). `active`
//! (pairs `coil:magnet` joined by `;`) is what is energised after the step and is authoritative;
//! `new_coil`/`new_magnet` list the newly energised pairs, joined by `;` when there are several.
//! `settled` (`true`/`false`) says whether the step settles in the dynamics within t_max (a
//! pivot plan's geometric step may not: its `settle_time_s` is then t_max). Files written
//! before the column was added read as settled throughout.
//!
//! A plan through waypoints (`plan --waypoints`) has five more columns: `waypoint` (the
//! waypoint the row serves: 1, 2, ...) and `waypoint_qx..waypoint_qw` (its orientation), so
//! that `simulate` can say where the ball ends against each; readers that do not need them
//! ignore them.

use crate::error::Result;
use crate::io::pairs::parse_pairs;
use crate::io::table::{write_csv, Row, Table};
use crate::model::geometry::{orientation_from_xyzw, xyzw, Orientation, Pair};
use crate::planning::plan::PlanRow;
use crate::planning::waypoints::WaypointPlan;
use std::io::Write;
use std::path::Path;

/// The plan CSV header, in column order.
pub const HEADER: [&str; 16] = [
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
    "settled",
];

/// The columns every plan file has; the last of [`HEADER`] (`settled`) may be missing, in a
/// file written before it was added.
pub const REQUIRED: usize = 15;

/// The columns a waypoint plan adds after [`HEADER`].
pub const WAYPOINT_COLUMNS: [&str; 5] = [
    "waypoint",
    "waypoint_qx",
    "waypoint_qy",
    "waypoint_qz",
    "waypoint_qw",
];

/// The waypoint a row of a plan file serves (1, 2, ...) and its orientation.
pub type Serves = (usize, Orientation);

fn join(v: impl Iterator<Item = String>) -> String {
    v.collect::<Vec<_>>().join(";")
}

/// Writes a plan as CSV (header, then one row per step). Numbers use Rust's shortest
/// round-trip formatting, so the same plan gives the same bytes.
pub fn write_plan(rows: &[PlanRow], out: &mut dyn Write) -> Result<()> {
    write_csv(out, "<plan output>", &HEADER, rows.iter().map(plan_record))
}

/// Writes a plan through waypoints: [`HEADER`] and [`WAYPOINT_COLUMNS`], one row per step.
pub fn write_waypoint_plan(p: &WaypointPlan, out: &mut dyn Write) -> Result<()> {
    let header: Vec<&str> = HEADER.iter().chain(&WAYPOINT_COLUMNS).copied().collect();
    let records = p.rows.iter().zip(&p.serves).map(|(r, &w)| {
        let mut rec = plan_record(r);
        rec.push(w.to_string());
        let q = p
            .waypoints
            .get(w.wrapping_sub(1))
            .map(xyzw)
            .unwrap_or_default();
        rec.extend(q.iter().map(|c| c.to_string()));
        rec
    });
    write_csv(out, "<plan output>", &header, records)
}

/// The waypoint each row of a plan file serves, with its orientation, row by row: `None` for a
/// plan without the [`WAYPOINT_COLUMNS`].
///
/// # Errors
/// A row whose waypoint is not a number from 1 or whose orientation is not a non-zero
/// quaternion; waypoints that go back (a row serving an earlier waypoint than the row before).
pub fn parse_plan_waypoints(text: &str, path: &Path) -> Result<Option<Vec<Serves>>> {
    let t = Table::parse(text, path)?;
    if t.column(WAYPOINT_COLUMNS[0]).is_none() {
        return Ok(None);
    }
    let idx: Vec<usize> = WAYPOINT_COLUMNS
        .iter()
        .map(|h| {
            t.require(
                h,
                " (a plan through waypoints has all five waypoint columns)",
            )
        })
        .collect::<Result<_>>()?;
    let mut out: Vec<Serves> = Vec::new();
    for r in t.rows() {
        let w = r.get(idx[0]);
        let k = w.parse::<usize>().ok().filter(|&k| k >= 1).ok_or_else(|| {
            r.error(format!(
                "column `waypoint`: expected a waypoint number (1, 2, ...), got '{w}'"
            ))
        })?;
        if let Some(&(before, _)) = out.last() {
            if k < before {
                return Err(r.error(format!(
                    "column `waypoint`: expected {before} or later after waypoint {before}, got {k}"
                )));
            }
        }
        let c: Vec<f64> = (1..5)
            .map(|j| r.finite(idx[j], WAYPOINT_COLUMNS[j]))
            .collect::<Result<_>>()?;
        let q = orientation_from_xyzw(c[0], c[1], c[2], c[3]).ok_or_else(|| {
            r.error("columns `waypoint_qx..waypoint_qw`: expected a non-zero quaternion".into())
        })?;
        out.push((k, q));
    }
    Ok(Some(out))
}

/// Where each waypoint of a plan is reached: the index of the last row serving it (of
/// `serves`, row by row, as [`parse_plan_waypoints`] gives them), in order. A waypoint no row
/// serves has none.
pub fn waypoint_ends(serves: &[Serves]) -> Vec<usize> {
    (0..serves.len())
        .filter(|&k| {
            serves
                .get(k + 1)
                .is_none_or(|(next, _)| *next != serves[k].0)
        })
        .collect()
}

/// [`parse_plan_waypoints`] of the plan file at `path`.
pub fn read_plan_waypoints(path: &Path) -> Result<Option<Vec<Serves>>> {
    let text = crate::io::input::text(path)?;
    parse_plan_waypoints(&text, path)
}

/// The fields of one plan row, in [`HEADER`]'s order.
fn plan_record(r: &PlanRow) -> Vec<String> {
    let q = xyzw(&r.q);
    vec![
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
        r.settled.to_string(),
    ]
}

/// Reads a plan CSV; any malformed row gives an error naming the file, line and column.
pub fn read_plan(path: &Path) -> Result<Vec<PlanRow>> {
    let text = crate::io::input::text(path)?;
    parse_plan(&text, path)
}

/// Parses plan CSV text (`path` names it in errors): steps 0, 1, 2, ... in order.
pub fn parse_plan(text: &str, path: &Path) -> Result<Vec<PlanRow>> {
    let t = Table::parse(text, path)?;
    let idx: Vec<usize> = HEADER[..REQUIRED]
        .iter()
        .map(|h| t.require(h, ""))
        .collect::<Result<_>>()?;
    let settled = t.column(HEADER[REQUIRED]);
    let mut rows: Vec<PlanRow> = Vec::new();
    for r in t.rows() {
        let row = plan_row(&r, &idx, settled)?;
        let expected = rows.last().map_or(0, |p| p.step + 1);
        if row.step != expected {
            return Err(r.error(match rows.last() {
                None => format!(
                    "column `step`: expected the first row to be step 0 (the initial commutation state), got {}",
                    row.step
                ),
                Some(p) => format!(
                    "column `step`: expected {expected} after step {}, got {}",
                    p.step, row.step
                ),
            }));
        }
        rows.push(row);
    }
    t.require_rows("step")?;
    Ok(rows)
}

/// One row of a plan file; `idx` holds the required columns of [`HEADER`], `settled` the
/// column `settled` if the file has it.
fn plan_row(r: &Row, idx: &[usize], settled: Option<usize>) -> Result<PlanRow> {
    let num = |k: usize| r.finite(idx[k], HEADER[k]);
    let q = orientation_from_xyzw(num(6)?, num(7)?, num(8)?, num(9)?)
        .ok_or_else(|| r.error("columns `qx..qw`: expected a non-zero quaternion".into()))?;
    let settle_time_s = num(14)?;
    if settle_time_s < 0.0 {
        return Err(r.error(format!(
            "column `settle_time_s`: expected a time >= 0 s, got {}",
            crate::text::shown(settle_time_s)
        )));
    }
    Ok(PlanRow {
        step: r.step(idx[0])?,
        pivot: pivot(r, idx[1], idx[2])?,
        new: new_pairs(r, idx[3], idx[4])?,
        active: active(r, idx[5])?,
        q,
        step_angle_deg: num(10)?,
        step_axis_error_deg: num(11)?,
        cum_angle_deg: num(12)?,
        cum_axis_error_deg: num(13)?,
        settle_time_s,
        settled: match settled.map(|c| r.get(c).trim()) {
            None | Some("true") => true,
            Some("false") => false,
            Some(other) => {
                return Err(r.error(format!(
                    "column `settled`: expected true or false, got '{other}'"
                )))
            }
        },
    })
}

/// The pivot pair: columns `pivot_coil` and `pivot_magnet`, both given or both empty.
fn pivot(r: &Row, coil: usize, magnet: usize) -> Result<Option<Pair>> {
    match (r.get(coil), r.get(magnet)) {
        ("", "") => Ok(None),
        (c, m) => format!("{c}:{m}").parse().map(Some).map_err(|()| {
            r.error(format!(
                "columns `pivot_coil`, `pivot_magnet`: expected two indices or both empty, got '{c}', '{m}'"
            ))
        }),
    }
}

/// The newly switched pairs: columns `new_coil` and `new_magnet`, indices joined by `;`.
fn new_pairs(r: &Row, coils: usize, magnets: usize) -> Result<Vec<Pair>> {
    let list = |col: usize, name: &str| -> Result<Vec<usize>> {
        let s = r.get(col);
        if s.is_empty() {
            return Ok(Vec::new());
        }
        s.split(';')
            .map(|x| x.trim().parse::<usize>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| {
                r.error(format!(
                    "column `{name}`: expected indices joined by ';', got '{s}'"
                ))
            })
    };
    let (nc, nm) = (list(coils, HEADER[3])?, list(magnets, HEADER[4])?);
    if nc.len() != nm.len() {
        return Err(
            r.error("columns `new_coil`, `new_magnet`: expected as many coils as magnets".into())
        );
    }
    Ok(nc
        .into_iter()
        .zip(nm)
        .map(|(c, m)| Pair::new(c, m))
        .collect())
}

/// The active set: column `active`, pairs joined by `;`, each coil once.
fn active(r: &Row, col: usize) -> Result<Vec<Pair>> {
    let active = parse_pairs(r.get(col), "active").map_err(|_| {
        r.error(format!(
            "column `active`: expected pairs coil:magnet joined by ';', got '{}'",
            r.get(col)
        ))
    })?;
    for (k, p) in active.iter().enumerate() {
        if active[..k].iter().any(|o| o.coil == p.coil) {
            return Err(r.error(format!(
                "column `active`: expected each coil once, got coil {} twice",
                p.coil
            )));
        }
    }
    Ok(active)
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
                settled: true,
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
                settled: false,
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
        assert!(back[0].settled && !back[1].settled);
    }

    #[test]
    fn waypoint_ends_are_the_last_rows_of_each_waypoint() {
        let q = UnitQuaternion::identity();
        let serves: Vec<Serves> = [1, 1, 1, 3, 4, 4].iter().map(|&w| (w, q)).collect();
        assert_eq!(waypoint_ends(&serves), vec![2, 3, 5]);
        assert_eq!(waypoint_ends(&serves[..1]), vec![0]);
        assert!(waypoint_ends(&[]).is_empty());
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
