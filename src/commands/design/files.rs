//! The design run's files: a layout written as a complete scenario (the spec's physics, body,
//! supply and plan settings, the layout's points, a sweep about the design's axes), a sweep's
//! per-axis results read back, and `front.csv` and `history.csv`.

use crate::error::{Error, Result};
use crate::model::geometry::UnitVec;
use crate::planning::design::layout::Layout;
use crate::planning::design::objectives::{AxisResult, Objectives, NAMES};
use std::path::{Path, PathBuf};

/// The spec's scenario as a TOML table without what a layout replaces: `name`, `description`,
/// `[rotor]`, `[stator]`, `[sweep]` and `[design]`; a relative `magnets.table` made absolute
/// (the layouts live in other folders).
pub(super) fn base_table(text: &str, file: &Path) -> Result<toml::Table> {
    let mut t: toml::Table = text.parse().map_err(|e: toml::de::Error| Error::Parse {
        file: file.to_path_buf(),
        message: e.to_string().trim_end().to_string(),
    })?;
    for k in ["name", "description", "rotor", "stator", "sweep", "design"] {
        t.remove(k);
    }
    let dir = file.parent().unwrap_or(Path::new("."));
    if let Some(toml::Value::Table(m)) = t.get_mut("magnets") {
        if let Some(toml::Value::String(p)) = m.get_mut("table") {
            let abs = std::path::absolute(dir.join(&*p)).unwrap_or_else(|_| dir.join(&*p));
            *p = abs.display().to_string();
        }
    }
    Ok(t)
}

fn points(pts: &[UnitVec]) -> toml::Value {
    toml::Value::Array(
        pts.iter()
            .map(|p| toml::Value::Array(vec![p.x.into(), p.y.into(), p.z.into()]))
            .collect(),
    )
}

/// The scenario of `layout` named `name`: `base` with the layout's packings and a sweep of
/// `angle_deg` about `axes`.
pub(super) fn layout_toml(
    base: &toml::Table,
    name: &str,
    description: &str,
    layout: &Layout,
    axes: &[UnitVec],
    angle_deg: f64,
) -> Result<String> {
    let mut t = toml::Table::new();
    t.insert("name".into(), name.into());
    t.insert("description".into(), description.into());
    let packing = |pts: &[UnitVec]| {
        let mut s = toml::Table::new();
        s.insert("points".into(), points(pts));
        toml::Value::Table(s)
    };
    t.insert("rotor".into(), packing(&layout.rotor));
    t.insert("stator".into(), packing(&layout.stator));
    t.extend(base.clone());
    let mut sweep = toml::Table::new();
    sweep.insert("axes".into(), points(axes));
    sweep.insert(
        "angles_deg".into(),
        toml::Value::Array(vec![angle_deg.into()]),
    );
    t.insert("sweep".into(), toml::Value::Table(sweep));
    toml::to_string(&t).map_err(|e| Error::Parse {
        file: PathBuf::from(name),
        message: format!("writing the layout's scenario: {e}"),
    })
}

/// The per-axis results of a sweep CSV as `batch` writes it.
pub(super) fn read_sweep(path: &Path) -> Result<Vec<AxisResult>> {
    let bad = |what: String| Error::Parse {
        file: path.to_path_buf(),
        message: what,
    };
    let mut r = csv::Reader::from_path(path).map_err(|e| bad(e.to_string()))?;
    let head = r.headers().map_err(|e| bad(e.to_string()))?.clone();
    let col = |name: &str| {
        head.iter()
            .position(|h| h == name)
            .ok_or_else(|| bad(format!("no column `{name}`")))
    };
    let (e, s, f) = (
        col("max_axis_error_deg")?,
        col("steps")?,
        col("final_orientation_error_deg")?,
    );
    let mut out = Vec::new();
    for rec in r.records() {
        let rec = rec.map_err(|e| bad(e.to_string()))?;
        let num = |k: usize| {
            rec.get(k)
                .and_then(|v| v.parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad(format!("column `{}`: expected a number", &head[k])))
        };
        out.push(AxisResult {
            axis_error_deg: num(e)?,
            steps: num(s)? as usize,
            final_error_deg: num(f)?,
        });
    }
    Ok(out)
}

/// One layout of the front: its name, layout, full objectives and scenario file (relative
/// to the output folder).
pub(super) struct FrontRow<'a> {
    pub(super) id: &'a str,
    pub(super) layout: &'a Layout,
    pub(super) objectives: Objectives,
    pub(super) scenario: String,
}

/// `front.csv`: one row per non-dominated layout: its name, family, counts, worst axis error
/// and the objectives but the coil count, and its scenario.
pub(super) fn front_csv(rows: &[FrontRow]) -> String {
    // the worst axis error (reported) first, then the objectives but the coil count, which is
    // the `coils` column already
    let mut s = format!(
        "layout,family,coils,magnets,worst_axis_error_deg,{},scenario\n",
        NAMES[..5].join(",")
    );
    for r in rows {
        let o = &r.objectives;
        let values: Vec<String> = std::iter::once(o.worst_axis_error_deg)
            .chain(o.values()[..5].iter().copied())
            .map(|v| v.to_string())
            .collect();
        s.push_str(&format!(
            "{},{},{},{},{},{}\n",
            r.id,
            r.layout.family.name(),
            r.layout.stator.len(),
            r.layout.rotor.len(),
            values.join(","),
            r.scenario
        ));
    }
    s
}

/// The header of `history.csv`.
pub(super) fn history_header() -> String {
    let best: Vec<String> = NAMES.iter().map(|n| format!("best_{n}")).collect();
    format!(
        "generation,evaluations,full_evaluations,front_size,{}\n",
        best.join(",")
    )
}
