//! The progress file of a sweep being computed: each finished case's row appended as the case
//! ends, so that a killed sweep is continued by `--resume` instead of starting over.

use super::{Job, SWEEP_HEADER};
use crate::error::{Error, Result};
use crate::io::output::write_atomic;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The progress file of a sweep result being computed (`NAME.csv.progress`): a first line
/// `hash HASH`, then the CSV row of each finished case, appended (one write per row) as the
/// case ends, so that a killed sweep is continued by `--resume`. Removed once the result is
/// written.
pub(super) fn progress_path(csv: &Path) -> PathBuf {
    let mut s = csv.as_os_str().to_owned();
    s.push(".progress");
    PathBuf::from(s)
}

/// The finished cases in `csv`'s progress file (case index -> row), when the file belongs to
/// this `hash`; a row cut short by a kill (no line end, or not a whole row) counts for nothing.
pub(super) fn read_progress(csv: &Path, hash: &str) -> BTreeMap<usize, Vec<String>> {
    let mut done = BTreeMap::new();
    let Ok(text) = std::fs::read_to_string(progress_path(csv)) else {
        return done;
    };
    let Some((first, rest)) = text.split_once('\n') else {
        return done;
    };
    if first.strip_prefix("hash ") != Some(hash) {
        return done;
    }
    let whole = &rest[..rest.rfind('\n').map_or(0, |k| k + 1)];
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_reader(whole.as_bytes());
    for rec in rdr.records().flatten() {
        if rec.len() != SWEEP_HEADER.len() {
            continue;
        }
        if let Ok(case) = rec[0].parse::<usize>() {
            done.insert(case, rec.iter().map(str::to_string).collect());
        }
    }
    done
}

/// One CSV row as bytes (with its line end).
pub(super) fn csv_line(record: &[String]) -> Result<Vec<u8>> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(record)
        .map_err(|e| Error::csv("<progress row>", e))?;
    w.into_inner()
        .map_err(|e| Error::io("<progress row>", e.into_error()))
}

/// Starts a job's progress file with the cases already `done`; the open file, to append to
/// (`None` when it cannot be written: the sweep then runs without saving progress).
pub(super) fn start_progress(
    job: &Job,
    done: &BTreeMap<usize, Vec<String>>,
) -> Option<std::sync::Mutex<std::fs::File>> {
    let path = progress_path(&job.csv);
    let mut bytes = format!("hash {}\n", job.hash).into_bytes();
    for r in done.values() {
        bytes.extend(csv_line(r).ok()?);
    }
    write_atomic(&path, &bytes).ok()?;
    let f = std::fs::OpenOptions::new().append(true).open(&path).ok()?;
    Some(std::sync::Mutex::new(f))
}

/// Appends a finished case's row to the progress file (one write, so a kill leaves whole rows
/// and at most one torn last row, which is ignored on reading).
pub(super) fn append_progress(file: &std::sync::Mutex<std::fs::File>, record: &[String]) {
    use std::io::Write;
    if let (Ok(line), Ok(mut f)) = (csv_line(record), file.lock()) {
        let _ = f.write_all(&line);
    }
}
