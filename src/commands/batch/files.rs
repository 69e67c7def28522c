//! The files of a batch job: the result with its content hash (what `--resume` checks), the
//! progress file of a sweep being computed, the merging of shard parts and the pictures.

use super::cases::{case_label, cases, sweep_row_problem, Case, Outcome};
use super::progress::progress_path;
use super::{Job, Shard, SWEEP_HEADER};
use crate::error::{Error, Result};
use crate::figures::batch_pictures;
use crate::io::input::{read_bytes, read_text};
use crate::io::output::write_atomic;
use crate::io::planfile::{parse_plan, write_plan};
use crate::io::scenario::Scenario;
use crate::io::table::{csv_bytes, Table};
use crate::planning::plan::PlanRow;
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// The content hash of a scenario's work: program version, the sweep CSV's columns (a result
/// written with other columns, e.g. before `max_path_deviation_deg`, is of other content and
/// computed again), the scenario as loaded (points, wells, settings) and which part of it.
pub(super) fn content_hash(sc: &Scenario, text: &str, part: &str) -> String {
    let mut h = Sha256::new();
    h.update(env!("CARGO_PKG_VERSION").as_bytes());
    h.update(SWEEP_HEADER.join(",").as_bytes());
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

/// The SHA-256 of a result's bytes, as its `.hash` records it.
fn digest(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// What `--resume` finds of a result.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Stored {
    /// No result of this content: none, one without its `.hash` (a killed run), or one of
    /// another scenario's content. Computed (again), silently.
    Absent,
    /// The result of this content, whole.
    Current,
    /// A `.hash` of this content beside a result that is not what was written (cut short,
    /// edited, replaced): the message, after the file's name. Computed again, with a warning.
    Damaged(String),
}

/// What is stored at `csv` for content `hash`. The `.hash` holds the content hash, then
/// `sha256 DIGEST` of the result's bytes, and the bytes are checked against it; a `.hash` of an
/// older spherestep (the content hash alone) has the result checked by `whole`, which says
/// what is wrong with its text, if anything.
pub(super) fn stored(csv: &Path, hash: &str, whole: impl FnOnce(&str) -> Option<String>) -> Stored {
    let hash_file = hash_path(csv);
    let Ok(recorded) = read_text(&hash_file) else {
        return Stored::Absent;
    };
    let mut lines = recorded.lines().map(str::trim);
    if lines.next() != Some(hash) || !csv.is_file() {
        return Stored::Absent;
    }
    let bytes = match read_bytes(csv) {
        Ok(b) => b,
        Err(e) => return Stored::Damaged(format!("unreadable ({e})")),
    };
    let not_whole = |why: String| {
        Stored::Damaged(format!(
            "its contents are not those of a whole result ({why})"
        ))
    };
    match lines.next() {
        Some(line) => match line.strip_prefix("sha256 ") {
            Some(d) if d == digest(&bytes) => Stored::Current,
            _ => Stored::Damaged(format!(
                "its contents are not those recorded in {} (cut short, edited or replaced)",
                hash_file.display()
            )),
        },
        None => match std::str::from_utf8(&bytes) {
            Err(_) => not_whole("not UTF-8 text".into()),
            Ok(text) => match whole(text) {
                Some(why) => not_whole(why),
                None => Stored::Current,
            },
        },
    }
}

/// What is wrong with `text` as the result of `cases` of `sc` written to `csv` (a plan, or a
/// sweep's rows of those cases in order), if anything: for results whose `.hash` records no
/// digest.
pub(super) fn result_problem(
    sc: &Scenario,
    cases: &[Case],
    csv: &Path,
    text: &str,
) -> Option<String> {
    if !text.ends_with('\n') {
        return Some("no line end at its end: cut short".into());
    }
    if sc.sweep.is_none() {
        return match parse_plan(text, csv) {
            Ok(rows) if rows.is_empty() => Some("no plan rows".into()),
            Ok(_) => None,
            Err(e) => Some(e.to_string()),
        };
    }
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_reader(text.as_bytes());
    let records: Vec<Vec<String>> = match rdr
        .records()
        .map(|r| r.map(|r| r.iter().map(str::to_string).collect()))
        .collect::<std::result::Result<_, _>>()
    {
        Ok(r) => r,
        Err(e) => return Some(format!("unreadable: {e}")),
    };
    let Some((head, rows)) = records.split_first() else {
        return Some("empty".into());
    };
    if *head != SWEEP_HEADER {
        return Some(format!("expected the header `{}`", SWEEP_HEADER.join(",")));
    }
    if rows.len() != cases.len() {
        return Some(format!(
            "expected {} case rows, got {}",
            cases.len(),
            rows.len()
        ));
    }
    rows.iter()
        .zip(cases)
        .enumerate()
        .find_map(|(k, (r, c))| sweep_row_problem(c, r).map(|p| format!("line {}: {p}", k + 2)))
}

/// Writes a result and then its hash, the content's and the result's (a killed run leaves at
/// worst a result without a hash, which --resume recomputes).
pub(super) fn write_with_hash(csv: &Path, bytes: &[u8], hash: &str) -> Result<()> {
    write_atomic(csv, bytes)?;
    let recorded = format!("{hash}\nsha256 {}\n", digest(bytes));
    write_atomic(&hash_path(csv), recorded.as_bytes())
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
    let Ok(text) = read_text(&pictures_path(csv)) else {
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

/// Merges the shard parts of a sweep, when a complete, up-to-date set of them is present; a
/// damaged part (see [`stored`]) is named in `warnings` and its set not merged.
pub(super) fn merge_parts(
    out: &Path,
    name: &str,
    sc: &Scenario,
    text: &str,
    warnings: &mut Vec<String>,
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
        let all = cases(sc);
        let mut complete = true;
        for (p, sh) in &parts {
            let mine: Vec<Case> = all.iter().filter(|c| sh.takes(c.index)).cloned().collect();
            let hash = content_hash(sc, text, &sh.suffix());
            match stored(p, &hash, |t| result_problem(sc, &mine, p, t)) {
                Stored::Current => {}
                Stored::Absent => complete = false,
                Stored::Damaged(why) => {
                    warnings.push(format!(
                        "{}: {why}: not merged, the sweep is computed whole",
                        p.display()
                    ));
                    complete = false;
                }
            }
        }
        if !complete {
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
