//! `spherestep plot` ([`plot_csv`]): the figure that suits an existing result CSV, told by its
//! header: a plan's axis error curve (a plan through waypoints: its path through them), a sweep's maps (one per scheme, and one of the pivot
//! model's floor when the sweep has that column), or a run's distance to the goal by step.

use crate::error::{Error, Result};
use crate::figures::axis_error::{plan_series, AxisErrorPlot};
use crate::figures::figure::write_figure;
use crate::figures::loop_plot::LoopPlot;
use crate::figures::sweep_csv::{
    parse_sweep, parse_sweep_column, parse_unreached, SweepPoints, FLOOR_COLUMN, SWEEP_COLUMNS,
};
use crate::figures::sweep_map::{value_range, SweepMap};
use crate::figures::waypoint_plot::WaypointPlot;
use crate::io::{loopfile, planfile};
use std::path::{Path, PathBuf};

/// Draws an existing result CSV (for `spherestep plot`), recognised by its header:
/// - a plan CSV (the columns of [`planfile::HEADER`]): a Figure 7-style plot of its cumulative
///   axis error against rotation angle, written as `STEM.svg` and `STEM.png`; a plan through
///   waypoints (with the waypoint columns): the ball's path through them, `STEM.svg/.png`;
/// - a sweep CSV (the columns [`SWEEP_COLUMNS`], optionally `scheme`): one map of the worst
///   axis error per scheme, `STEM_SCHEME.svg/.png` (or `STEM.svg/.png` without `scheme`);
/// - a run CSV (`spherestep run`, `simulate --closed-loop`: the columns of
///   [`loopfile::HEADER`]): the distance to the goal by step, `STEM.svg/.png`.
///
/// STEM is the CSV's file stem; the pictures go to `out_dir` (created if missing), by default
/// next to the CSV. Returns the files written.
pub fn plot_csv(
    csv_path: &Path,
    out_dir: Option<&Path>,
    title: Option<&str>,
) -> Result<Vec<PathBuf>> {
    plot_csv_with_coils(csv_path, out_dir, title, &[])
}

/// [`plot_csv`], with the stator's coil directions drawn on a sweep's maps.
pub fn plot_csv_with_coils(
    csv_path: &Path,
    out_dir: Option<&Path>,
    title: Option<&str>,
    coils: &[[f64; 3]],
) -> Result<Vec<PathBuf>> {
    let text = crate::io::input::text(csv_path)?;
    let header = csv_header(&text);
    let kind = csv_kind(&header, csv_path)?;
    let csv = ResultCsv {
        path: csv_path,
        text: &text,
        stem: csv_stem(csv_path),
        dir: out_dir_for(csv_path, out_dir),
        coils,
    };
    std::fs::create_dir_all(&csv.dir).map_err(|e| Error::io(&csv.dir, e))?;
    match kind {
        Kind::Plan => csv.plan_figure(title),
        Kind::Loop => csv.loop_figure(title),
        Kind::Sweep => {
            let groups = parse_sweep(&text, csv_path)?;
            // One colour scale for all the maps, so that they can be compared.
            let range = value_range(groups.iter().flat_map(|g| g.1.iter().map(|p| p.1)));
            let mut written = csv.scheme_maps(groups, range, title)?;
            if header.iter().any(|h| h == FLOOR_COLUMN) {
                written.extend(csv.floor_map(range)?);
            }
            Ok(written)
        }
    }
}

/// What a result CSV holds, told by its header.
enum Kind {
    Plan,
    Sweep,
    Loop,
}

/// A result CSV being drawn: where it is, its text, its file stem, where its pictures go and
/// the coil directions to draw on a sweep's maps.
struct ResultCsv<'a> {
    path: &'a Path,
    text: &'a str,
    stem: String,
    dir: PathBuf,
    coils: &'a [[f64; 3]],
}

/// The CSV's file stem ("plot" if it has none).
fn csv_stem(csv_path: &Path) -> String {
    csv_path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "plot".into())
}

/// Where the pictures go: `out_dir`, else the CSV's folder.
fn out_dir_for(csv_path: &Path, out_dir: Option<&Path>) -> PathBuf {
    match out_dir {
        Some(d) => d.to_path_buf(),
        None => match csv_path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        },
    }
}

/// The CSV's column names, trimmed (none if it has no header).
fn csv_header(text: &str) -> Vec<String> {
    csv::ReaderBuilder::new()
        .has_headers(true)
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes())
        .headers()
        .map(|h| h.iter().map(str::to_string).collect())
        .unwrap_or_default()
}

/// A plan CSV if the header has every plan column, else a sweep CSV if it has every sweep
/// column, else an error naming what was found and what is expected.
fn csv_kind(header: &[String], csv_path: &Path) -> Result<Kind> {
    let has = |c: &str| header.iter().any(|h| h == c);
    // a plan file from before the `settled` column is a plan file all the same
    if planfile::HEADER[..planfile::REQUIRED]
        .iter()
        .all(|c| has(c))
    {
        return Ok(Kind::Plan);
    }
    if SWEEP_COLUMNS.iter().all(|c| has(c)) {
        return Ok(Kind::Sweep);
    }
    if loopfile::HEADER.iter().all(|c| has(c)) {
        return Ok(Kind::Loop);
    }
    let found = if header.iter().all(|h| h.is_empty()) {
        "no columns".to_string()
    } else {
        format!("columns {}", header.join(", "))
    };
    Err(Error::Parse {
        file: csv_path.to_path_buf(),
        message: format!(
            "not a plan, sweep or run CSV (found {found}); expected a plan CSV with the \
             columns {}, a sweep CSV with the columns {} (and optionally scheme), or a run CSV \
             with the columns {}",
            planfile::HEADER[..planfile::REQUIRED].join(", "),
            SWEEP_COLUMNS.join(", "),
            loopfile::HEADER.join(", ")
        ),
    })
}

/// A scheme name made safe for a file name.
fn file_safe(s: &str) -> String {
    crate::io::output::file_safe(s, "unnamed")
}

impl ResultCsv<'_> {
    /// A plan's axis error curve, `STEM.svg/.png`.
    fn plan_figure(&self, title: Option<&str>) -> Result<Vec<PathBuf>> {
        let rows = planfile::parse_plan(self.text, self.path)?;
        if let Some(serves) = planfile::parse_plan_waypoints(self.text, self.path)? {
            return self.waypoint_figure(&rows, &serves, title);
        }
        let fig = AxisErrorPlot {
            title: title
                .map(str::to_string)
                .unwrap_or_else(|| format!("axis error vs. rotation angle: {}", self.stem)),
            series: vec![plan_series(&self.stem, &rows)],
            reference: None,
            target_deg: None,
        };
        write_figure(&fig, &self.dir.join(&self.stem))
    }

    /// A plan through waypoints: the ball's path and the waypoints, `STEM.svg/.png`.
    fn waypoint_figure(
        &self,
        rows: &[crate::planning::plan::PlanRow],
        serves: &[planfile::Serves],
        title: Option<&str>,
    ) -> Result<Vec<PathBuf>> {
        let deg = |q: &crate::model::geometry::Orientation| {
            let v = q.scaled_axis() * (180.0 / std::f64::consts::PI);
            [v.x, v.y, v.z]
        };
        // each waypoint at the last row serving it
        let waypoints = planfile::waypoint_ends(serves)
            .into_iter()
            .filter_map(|k| {
                let (_, q) = &serves[k];
                rows.get(k)
                    .map(|r| (deg(q), k, r.q.angle_to(q).to_degrees()))
            })
            .collect();
        let fig = WaypointPlot {
            title: title
                .map(str::to_string)
                .unwrap_or_else(|| format!("the path through the waypoints: {}", self.stem)),
            path: rows.iter().map(|r| deg(&r.q)).collect(),
            waypoints,
        };
        write_figure(&fig, &self.dir.join(&self.stem))
    }

    /// A run's distance to the goal by step, `STEM.svg/.png`.
    fn loop_figure(&self, title: Option<&str>) -> Result<Vec<PathBuf>> {
        let fig = LoopPlot {
            title: title
                .map(str::to_string)
                .unwrap_or_else(|| format!("distance to the goal by step: {}", self.stem)),
            rows: loopfile::parse_loop(self.text, self.path)?,
        };
        write_figure(&fig, &self.dir.join(&self.stem))
    }

    /// A map of the sweep's values `points` at `file` (under the output folder), on the
    /// colour scale `range` shared by all the sweep's maps, with the coils' axes.
    fn map(
        &self,
        file: &str,
        title: String,
        value_label: &str,
        points: Vec<([f64; 3], f64)>,
        unreached: Vec<[f64; 3]>,
        range: (f64, f64),
    ) -> Result<Vec<PathBuf>> {
        let fig = SweepMap {
            title,
            value_label: value_label.into(),
            points,
            range: Some(range),
            unreached,
            coils: self.coils.to_vec(),
        };
        write_figure(&fig, &self.dir.join(file))
    }

    /// One map of the worst axis error per scheme of `groups`, `STEM_SCHEME` (`STEM` without
    /// schemes).
    fn scheme_maps(
        &self,
        groups: Vec<SweepPoints>,
        range: (f64, f64),
        title: Option<&str>,
    ) -> Result<Vec<PathBuf>> {
        let unreached = parse_unreached(self.text, self.path)?;
        let stem = &self.stem;
        let mut written = Vec::new();
        for (scheme, points) in groups {
            let base = title
                .map(str::to_string)
                .unwrap_or_else(|| format!("worst axis error over the sphere of axes: {stem}"));
            let (title, file) = match &scheme {
                Some(s) => (
                    format!("{base}, scheme {s}"),
                    format!("{stem}_{}", file_safe(s)),
                ),
                None => (base, stem.clone()),
            };
            let missed = unreached.iter().filter(|u| u.0 == scheme).map(|u| u.1);
            written.extend(self.map(
                &file,
                title,
                "worst axis error (deg)",
                points,
                missed.collect(),
                range,
            )?);
        }
        Ok(written)
    }

    /// The map of the pivot model's floor, `STEM_pivot-floor`: the floor depends on the axis
    /// alone, so one map, from the first scheme's cases, on the schemes' colour scale `range`.
    fn floor_map(&self, range: (f64, f64)) -> Result<Vec<PathBuf>> {
        let floor = parse_sweep_column(self.text, self.path, FLOOR_COLUMN)?;
        let Some((_, points)) = floor.into_iter().next() else {
            return Ok(Vec::new());
        };
        let stem = &self.stem;
        self.map(
            &format!("{stem}_pivot-floor"),
            format!("pivot model's floor (nearest coil axis line) over the sphere of axes: {stem}"),
            "floor of the worst axis error (deg)",
            points,
            Vec::new(),
            range,
        )
    }
}
