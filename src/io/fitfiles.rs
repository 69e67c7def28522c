//! The files of `spherestep fit`: a bench's torque curve (`angle_deg,torque_nm`, the columns
//! `spherestep wells` writes), a closed-loop replay's log (`replay --sensor --log`: which coils
//! each step switched, and the sensor's reading after it) read as measured steps, and the
//! fitted scenario written back as TOML (the scenario's own file with its `[magnets]` replaced,
//! or a physical scenario's `core_gain` and `gap_m`).

use crate::error::{Error, Result};
use crate::io::table::Table;
use crate::model::geometry::{CoilId, Orientation};
use crate::physics::torque::Interaction;
use crate::planning::fit::{FitShape, MeasuredStep, WellFit, MIN_CURVE_POINTS};
use crate::planning::fit_parts::PartsValues;
use crate::text::shown;
use nalgebra::Quaternion;
use std::collections::BTreeSet;
use std::path::Path;

/// What a bench curve's columns are, appended to the errors about them.
const BENCH_HINT: &str =
    " (a bench curve: angle_deg in degrees and torque_nm in N m, as `spherestep wells` writes)";
/// What a replay log's columns are, appended to the errors about them.
const LOG_HINT: &str = " (a closed-loop replay's log, as `replay --sensor --log` writes)";

/// A bench's torque curve read from `path`: (degrees, N m) rows.
pub fn read_bench(path: &Path) -> Result<Vec<(f64, f64)>> {
    parse_bench(&crate::io::input::text(path)?, path)
}

/// A bench's torque curve from CSV text (`path` names it in errors): at least
/// [`MIN_CURVE_POINTS`] rows, angles in [0, 180] degrees, torques finite.
pub fn parse_bench(text: &str, path: &Path) -> Result<Vec<(f64, f64)>> {
    let t = Table::parse(text, path)?;
    let a = t.require("angle_deg", BENCH_HINT)?;
    let g = t.require("torque_nm", BENCH_HINT)?;
    let mut rows = Vec::new();
    for r in t.rows() {
        let angle = r.finite(a, "angle_deg")?;
        if !(0.0..=180.0).contains(&angle) {
            return Err(r.error(format!(
                "column `angle_deg`: expected an angle in [0, 180] degrees, got {}",
                shown(angle)
            )));
        }
        rows.push((angle, r.finite(g, "torque_nm")?));
    }
    if rows.len() < MIN_CURVE_POINTS {
        return Err(Error::Parse {
            file: path.to_path_buf(),
            message: format!(
                "expected at least {MIN_CURVE_POINTS} rows of angle_deg,torque_nm to fit a \
                 well to, got {}",
                rows.len()
            ),
        });
    }
    Ok(rows)
}

/// The measured steps of a closed-loop replay's log at `path`, for a motor of `coils` coils.
pub fn read_steps(path: &Path, coils: usize) -> Result<Vec<MeasuredStep>> {
    parse_steps(&crate::io::input::text(path)?, path, coils)
}

/// The log's columns this reader needs.
struct LogColumns {
    action: usize,
    coil: usize,
    q: [usize; 4],
}

/// A `sensor` row's quaternion (`qw,qx,qy,qz` columns), of norm within 0.01 of 1, normalised.
fn reading(r: &crate::io::table::Row<'_>, c: &LogColumns) -> Result<Orientation> {
    let mut v = [0.0; 4];
    for (k, name) in ["qw", "qx", "qy", "qz"].into_iter().enumerate() {
        v[k] = r.finite(c.q[k], name)?;
    }
    let q = Quaternion::new(v[0], v[1], v[2], v[3]);
    if (q.norm() - 1.0).abs() > 0.01 {
        return Err(r.error(format!(
            "columns `qw,qx,qy,qz`: expected a unit quaternion (norm within 0.01 of 1), got norm {}",
            shown(q.norm())
        )));
    }
    Ok(Orientation::from_quaternion(q))
}

/// The measured steps of a closed-loop replay's log (CSV text, `path` naming it in errors):
/// each `sensor` row after an earlier one of the same run (a `start` row begins a run, every
/// coil off) is a step from the earlier reading, with the coils on (`on` and `hold` rows switch
/// a coil on, `off` rows off; an `off` row without a coil, all of them).
pub fn parse_steps(text: &str, path: &Path, coils: usize) -> Result<Vec<MeasuredStep>> {
    let t = Table::parse(text, path)?;
    let req = |n: &str| t.require(n, LOG_HINT);
    let c = LogColumns {
        action: req("action")?,
        coil: req("coil")?,
        q: [req("qw")?, req("qx")?, req("qy")?, req("qz")?],
    };
    let mut on: BTreeSet<usize> = BTreeSet::new();
    // the last reading, the coils on at it, and the reading before (where they were switched on)
    let mut last: Option<(Orientation, Vec<CoilId>, Option<Orientation>)> = None;
    let mut steps = Vec::new();
    for r in t.rows() {
        let coil = || -> Result<Option<usize>> {
            let s = r.get(c.coil);
            if s.is_empty() || s == "-" {
                return Ok(None);
            }
            match s.parse::<usize>() {
                Ok(k) if k < coils => Ok(Some(k)),
                _ => Err(r.error(format!(
                    "column `coil`: expected a coil of the scenario (0 to {}), got '{s}'",
                    coils.saturating_sub(1)
                ))),
            }
        };
        match r.get(c.action) {
            "start" => {
                on.clear();
                last = None;
            }
            "on" | "hold" => on.extend(coil()?),
            "off" => match coil()? {
                Some(k) => _ = on.remove(&k),
                None => on.clear(),
            },
            "sensor" => {
                let q = reading(&r, &c)?;
                let coils: Vec<CoilId> = on.iter().map(|&k| CoilId(k)).collect();
                let before = last.take();
                if let (Some((from, held_by, since)), false) = (&before, on.is_empty()) {
                    steps.push(MeasuredStep {
                        from: *from,
                        held_by: held_by.clone(),
                        held_since: since.unwrap_or(*from),
                        coils: coils.clone(),
                        to: q,
                    });
                }
                last = Some((q, coils, before.map(|b| b.0)));
            }
            _ => {}
        }
    }
    if steps.is_empty() {
        return Err(Error::Parse {
            file: path.to_path_buf(),
            message: format!(
                "expected measured steps: `sensor` rows, each after an earlier one of the same \
                 run with coils on{LOG_HINT}"
            ),
        });
    }
    Ok(steps)
}

/// The scenario's `[magnets]` for the fitted wells.
fn magnets_table(wells: &WellFit, interaction: Interaction) -> toml::Table {
    let mut m = toml::Table::new();
    m.insert("shape".into(), wells.shape.name().into());
    m.insert("strength_j".into(), wells.strength_j.into());
    if let (FitShape::Gaussian, Some(w)) = (wells.shape, wells.width_deg) {
        m.insert("width_deg".into(), w.into());
    }
    m.insert("max_attraction_deg".into(), wells.reach_deg.into());
    let pulls = match interaction {
        Interaction::Pairs => "pairs",
        Interaction::Coils => "coils",
    };
    m.insert("interaction".into(), pulls.into());
    m
}

/// Relative point files (`rotor.file`, `stator.file`) made absolute when the fitted file goes
/// to another folder than the scenario's, so that it reads the same points.
fn keep_files(doc: &mut toml::Table, from_dir: &Path, out: &Path) {
    let out_dir = out.parent().unwrap_or(Path::new(""));
    let same = |a: &Path, b: &Path| match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => a == b,
    };
    let from = if from_dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        from_dir
    };
    let to = if out_dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        out_dir
    };
    if same(from, to) {
        return;
    }
    for section in ["rotor", "stator"] {
        let Some(toml::Value::Table(t)) = doc.get_mut(section) else {
            continue;
        };
        if let Some(toml::Value::String(f)) = t.get_mut("file") {
            if Path::new(f.as_str()).is_relative() {
                let abs = from.join(&*f);
                let abs = abs.canonicalize().unwrap_or(abs);
                *f = abs.display().to_string();
            }
        }
    }
}

/// What a fitted scenario replaces: its wells, or a physical scenario's `core_gain` and `gap_m`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fitted {
    /// `[magnets]` replaced by these wells with this interaction.
    Wells(WellFit, Interaction),
    /// `magnets.core_gain` and `magnets.gap_m` replaced, the rest of `[magnets]` kept.
    Parts(PartsValues),
}

/// The fitted scenario as TOML, to be written to `out`: the scenario's file (or, for the
/// built-in prototype, its name alone) with `[magnets]` the fitted wells (or its `core_gain`
/// and `gap_m` the fitted parts'), `name` and `description` saying so, after a comment `header`
/// (lines starting `# `).
pub fn fitted_toml(
    sc: &crate::io::scenario::Scenario,
    fitted: &Fitted,
    out: &Path,
    header: &str,
) -> Result<String> {
    let from_file = sc.files.first() == Some(&sc.path);
    let mut doc: toml::Table = if from_file {
        let text = crate::io::input::text(&sc.path)?;
        text.parse().map_err(|e: toml::de::Error| Error::Parse {
            file: sc.path.clone(),
            message: e.to_string(),
        })?
    } else {
        toml::Table::new()
    };
    if from_file {
        keep_files(&mut doc, sc.path.parent().unwrap_or(Path::new("")), out);
    }
    doc.insert("name".into(), format!("{}-fitted", sc.name).into());
    let what = match fitted {
        Fitted::Wells(..) => "its wells",
        Fitted::Parts(_) => "its core_gain and gap_m",
    };
    doc.insert(
        "description".into(),
        format!("{}, {what} fitted by spherestep fit", sc.name).into(),
    );
    match fitted {
        Fitted::Wells(wells, interaction) => {
            doc.insert("magnets".into(), magnets_table(wells, *interaction).into());
        }
        Fitted::Parts(v) => {
            let Some(toml::Value::Table(m)) = doc.get_mut("magnets") else {
                return Err(Error::Parse {
                    file: sc.path.clone(),
                    message: "writing the fitted parts: expected the scenario's file with its \
                              [magnets] (shape = \"dipole\")"
                        .into(),
                });
            };
            m.insert("core_gain".into(), v.core_gain.into());
            m.insert("gap_m".into(), v.gap_m.into());
        }
    }
    let body = toml::to_string(&doc).map_err(|e| Error::Parse {
        file: out.to_path_buf(),
        message: format!("writing the fitted scenario: {e}"),
    })?;
    Ok(format!("{header}{body}"))
}
