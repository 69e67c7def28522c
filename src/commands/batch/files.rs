//! The files of a batch job: the result with its content hash (what `--resume` checks), the
//! progress file of a sweep being computed, the merging of shard parts and the pictures.

use super::cases::{case_label, Outcome};
use super::progress::progress_path;
use super::{Job, Shard, SWEEP_HEADER};
use crate::error::{Error, Result};
use crate::figures::batch_pictures;
use crate::io::output::write_atomic;
use crate::io::planfile::write_plan;
use crate::io::scenario::Scenario;
use crate::io::table::{csv_bytes, Table};
use crate::planning::plan::PlanRow;
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// The content hash of a scenario's work: program version, the scenario as loaded (points,
/// wells, settings) and which part of it.
pub(super) fn content_hash(sc: &Scenario, text: &str, part: &str) -> String {
    let mut h = Sha256::new();
    h.update(env!("CARGO_PKG_VERSION").as_bytes());
    h.update(text.as_bytes());
    h.update(format!("{:?}", sc.torques).as_bytes());
    h.update(format!("{:?}{:?}{:?}{:?}", sc.body, sc.settle, sc.plan, sc.sweep).as_bytes());
    h.update(part.as_bytes());
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

pub(super) fn hash_path(csv: &Path) -> PathBuf {
    let mut s = csv.as_os_str().to_owned();
    s.push(".hash");
    PathBuf::from(s)
}

pub(super) fn up_to_date(csv: &Path, hash: &str) -> bool {
    csv.is_file() && std::fs::read_to_string(hash_path(csv)).is_ok_and(|h| h.trim() == hash)
}

/// Writes a result and then its hash (a killed run leaves at worst a result without a hash,
/// which --resume recomputes).
pub(super) fn write_with_hash(csv: &Path, bytes: &[u8], hash: &str) -> Result<()> {
    write_atomic(csv, bytes)?;
    write_atomic(&hash_path(csv), format!("{hash}\n").as_bytes())
}

pub(super) fn write_job(job: &Job, outcomes: &[Outcome]) -> Result<()> {
    match &job.scenario.sweep {
        None => {
            let o = outcomes.first().ok_or_else(|| Error::Arg {
                arg: job.name.clone(),
                expected: "one plan".into(),
            })?;
            let mut buf = Vec::new();
            write_plan(&o.rows, &mut buf)?;
            write_with_hash(&job.csv, &buf, &job.hash)
        }
        Some(_) => {
            if let Some(e) = outcomes.iter().find_map(|o| o.error.as_ref()) {
                return Err(Error::io(&job.csv, std::io::Error::other(e.to_string())));
            }
            let what = job.csv.display().to_string();
            let records = outcomes.iter().map(|o| o.record.clone());
            let bytes = csv_bytes(&what, &SWEEP_HEADER, records)?;
            write_with_hash(&job.csv, &bytes, &job.hash)?;
            let _ = std::fs::remove_file(progress_path(&job.csv));
            Ok(())
        }
    }
}

/// Whether `--plots` draws pictures for this result file (shard parts have none).
pub(super) fn draws(csv: &Path) -> bool {
    !csv.to_string_lossy().contains(".shard-")
}

/// The list of a result's pictures (`NAME.csv.pictures`): `hash HASH`, then one file name a
/// line. Written after the last picture, so a kill while drawing leaves none.
pub(super) fn pictures_path(csv: &Path) -> PathBuf {
    let mut s = csv.as_os_str().to_owned();
    s.push(".pictures");
    PathBuf::from(s)
}

/// Whether every picture of the result `csv` (of this `hash`) is in `out`.
pub(super) fn pictures_ok(csv: &Path, hash: &str, out: &Path) -> bool {
    let Ok(text) = std::fs::read_to_string(pictures_path(csv)) else {
        return false;
    };
    let mut lines = text.lines();
    lines.next().and_then(|l| l.strip_prefix("hash ")) == Some(hash)
        && lines.all(|f| out.join(f).is_file())
}

/// The pictures of a job (`--plots`): a plan's figures and page (from its file); a sweep's
/// per-scheme figure and last plan's (one motion, from `outcomes`) or maps (many axes, from its
/// file). Their list goes last.
pub(super) fn draw_job(job: &Job, outcomes: &[Outcome], out: &Path) -> Result<()> {
    let sc = &job.scenario;
    if !draws(&job.csv) {
        return Ok(());
    }
    let mut files = Vec::new();
    match &sc.sweep {
        None => {
            if let Some(c) = job.cases.first() {
                // From the plan as written, so that pictures drawn again by --resume (from the
                // file) are the same bytes.
                let rows = crate::io::planfile::read_plan(&job.csv)?;
                files = batch_pictures::plan_pictures(
                    sc,
                    &c.settings.axis,
                    &case_label(c),
                    &rows,
                    out,
                    &job.name,
                )?;
            }
        }
        Some(sw) => {
            if sw.axes.len() > 1 {
                files = batch_pictures::sweep_pictures(sc, &job.csv, out)?;
            } else {
                let plans: Vec<(String, Vec<PlanRow>)> = job
                    .cases
                    .iter()
                    .zip(outcomes)
                    .map(|(c, o)| (case_label(c), o.rows.clone()))
                    .collect();
                files = batch_pictures::schemes_picture(sc, &plans, out, &job.name)?;
                if let (Some(c), Some(o)) = (job.cases.last(), outcomes.last()) {
                    files.extend(batch_pictures::plan_pictures(
                        sc,
                        &c.settings.axis,
                        &case_label(c),
                        &o.rows,
                        out,
                        &job.name,
                    )?);
                }
            }
        }
    }
    let mut list = format!("hash {}\n", job.hash);
    for f in &files {
        if let Some(n) = f.file_name() {
            list.push_str(&format!("{}\n", n.to_string_lossy()));
        }
    }
    write_atomic(&pictures_path(&job.csv), list.as_bytes())
}

/// Merges the shard parts of a sweep, when a complete, up-to-date set of them is present.
pub(super) fn merge_parts(
    out: &Path,
    name: &str,
    sc: &Scenario,
    text: &str,
) -> Result<Option<Vec<u8>>> {
    let prefix = format!("{name}.shard-");
    let mut counts: Vec<usize> = Vec::new();
    if let Ok(rd) = std::fs::read_dir(out) {
        for e in rd.flatten() {
            let n = e.file_name().to_string_lossy().into_owned();
            if let Some(rest) = n.strip_prefix(&prefix).and_then(|r| r.strip_suffix(".csv")) {
                if let Some((_, c)) = rest.split_once("-of-") {
                    if let Ok(c) = c.parse::<usize>() {
                        if !counts.contains(&c) {
                            counts.push(c);
                        }
                    }
                }
            }
        }
    }
    counts.sort();
    for count in counts {
        let parts: Vec<(PathBuf, Shard)> = (0..count)
            .map(|index| {
                let sh = Shard { index, count };
                (out.join(format!("{name}.{}.csv", sh.suffix())), sh)
            })
            .collect();
        if !parts
            .iter()
            .all(|(p, sh)| up_to_date(p, &content_hash(sc, text, &sh.suffix())))
        {
            continue;
        }
        let mut rows: Vec<(usize, Vec<String>)> = Vec::new();
        for (p, _) in &parts {
            let t = Table::read(p)?;
            for r in t.rows() {
                let case = r
                    .get(0)
                    .parse::<usize>()
                    .map_err(|_| r.error("column `case`: expected a case number".into()))?;
                rows.push((case, r.fields()));
            }
        }
        rows.sort_by_key(|r| r.0);
        let what = out.join(format!("{name}.csv")).display().to_string();
        let records = rows.into_iter().map(|r| r.1);
        return Ok(Some(csv_bytes(&what, &SWEEP_HEADER, records)?));
    }
    Ok(None)
}
