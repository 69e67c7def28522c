//! The waypoints file of `plan --waypoints`: a CSV of the orientations a motion visits in
//! order, as absolute orientations (columns `qx,qy,qz,qw`, body to world) or as turns, each
//! applied (world frame) to the waypoint before it, the first to the start (columns
//! `axis_x,axis_y,axis_z,angle_deg`). Other columns (a label, say) are ignored.

use crate::error::Result;
use crate::io::table::Table;
use crate::model::geometry::{orientation_from_xyzw, rot_q, unit, Degrees, Orientation};
use nalgebra::Vector3;
use std::path::Path;

/// The columns of a file of absolute orientations.
pub const ORIENTATION_COLUMNS: [&str; 4] = ["qx", "qy", "qz", "qw"];

/// The columns of a file of turns.
pub const TURN_COLUMNS: [&str; 4] = ["axis_x", "axis_y", "axis_z", "angle_deg"];

/// The waypoints in the file at `path`; turns count from `start`.
///
/// # Errors
/// The file cannot be read, has neither set of columns (or both), has no row, or a row holds
/// something else than a non-zero quaternion or a non-zero axis and a finite angle: the error
/// names the file, the line and the column.
pub fn read_waypoints(path: &Path, start: &Orientation) -> Result<Vec<Orientation>> {
    let text = crate::io::input::text(path)?;
    parse_waypoints(&text, path, start)
}

/// Parses waypoints text (`path` names it in errors); turns count from `start`.
pub fn parse_waypoints(text: &str, path: &Path, start: &Orientation) -> Result<Vec<Orientation>> {
    let t = Table::parse(text, path)?;
    let has = |cols: &[&str]| cols.iter().all(|c| t.column(c).is_some());
    let absolute = match (has(&ORIENTATION_COLUMNS), has(&TURN_COLUMNS)) {
        (true, false) => true,
        (false, true) => false,
        (both, _) => {
            return Err(t.error(
                1,
                format!(
                    "expected the columns {} (orientations) or {} (turns, each from the \
                     waypoint before){}",
                    ORIENTATION_COLUMNS.join(","),
                    TURN_COLUMNS.join(","),
                    if both { ", not both" } else { "" }
                ),
            ))
        }
    };
    let names = if absolute {
        ORIENTATION_COLUMNS
    } else {
        TURN_COLUMNS
    };
    let idx: Vec<usize> = names
        .iter()
        .map(|c| t.require(c, ""))
        .collect::<Result<_>>()?;
    let mut out: Vec<Orientation> = Vec::new();
    for r in t.rows() {
        let v: Vec<f64> = idx
            .iter()
            .zip(names)
            .map(|(&k, name)| r.finite(k, name))
            .collect::<Result<_>>()?;
        let q = if absolute {
            orientation_from_xyzw(v[0], v[1], v[2], v[3])
                .ok_or_else(|| r.error("columns `qx..qw`: expected a non-zero quaternion".into()))?
        } else {
            let axis = unit(Vector3::new(v[0], v[1], v[2])).ok_or_else(|| {
                r.error("columns `axis_x..axis_z`: expected a non-zero axis".into())
            })?;
            let before = out.last().copied().unwrap_or(*start);
            rot_q(&axis, Degrees(v[3]).to_radians()) * before
        };
        out.push(q);
    }
    t.require_rows("waypoint")?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn turns_chain_from_the_start_and_orientations_are_taken_as_they_are() {
        let start = Orientation::identity();
        let p = Path::new("w.csv");
        let turns = parse_waypoints(
            "axis_x,axis_y,axis_z,angle_deg\n0,0,1,90\n0,0,2,90\n",
            p,
            &start,
        )
        .unwrap();
        let z = unit(Vector3::z()).unwrap();
        assert!(turns[0].angle_to(&rot_q(&z, Degrees(90.0).to_radians())) < 1e-12);
        assert!(turns[1].angle_to(&rot_q(&z, Degrees(180.0).to_radians())) < 1e-12);
        let abs = parse_waypoints("label,qx,qy,qz,qw\na,0,0,0,2\n", p, &start).unwrap();
        assert!(abs[0].angle_to(&start) < 1e-15);
    }

    #[test]
    fn bad_files_name_the_line_and_the_column() {
        let start = Orientation::identity();
        let p = Path::new("w.csv");
        let e = |t: &str| parse_waypoints(t, p, &start).unwrap_err().to_string();
        assert!(e("x,y\n1,2\n").contains("qx,qy,qz,qw"));
        assert!(e("qx,qy,qz,qw,axis_x,axis_y,axis_z,angle_deg\n").contains("not both"));
        let m = e("qx,qy,qz,qw\n0,0,0,1\n0,0,0,0\n");
        assert!(
            m.contains("w.csv: line 3") && m.contains("non-zero quaternion"),
            "{m}"
        );
        let m = e("axis_x,axis_y,axis_z,angle_deg\n0,0,0,10\n");
        assert!(m.contains("line 2") && m.contains("non-zero axis"), "{m}");
        let m = e("axis_x,axis_y,axis_z,angle_deg\n0,0,1,abc\n");
        assert!(m.contains("`angle_deg`"), "{m}");
        assert!(e("qx,qy,qz,qw\n").contains("at least one waypoint"));
    }
}
