//! The progress file of a sweep being computed: each finished case's row appended as the case
//! ends, with a checksum, so that a killed sweep is continued by `--resume` instead of starting
//! over, and a row that is not what was written is computed again instead of kept.

use super::{Job, SWEEP_HEADER};
use crate::error::{Error, Result};
use crate::io::output::write_atomic;
use crate::text::printable;
use sha2::{Digest, Sha256};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The progress file of a sweep result being computed (`NAME.csv.progress`): a first line
/// `hash HASH`, then the CSV row of each finished case followed by its [`row_check`],
/// appended (one write per row) as the case ends, so that a killed sweep is continued by
/// `--resume`. Removed once the result is written.
pub(super) fn progress_path(csv: &Path) -> PathBuf {
    let mut s = csv.as_os_str().to_owned();
    s.push(".progress");
    PathBuf::from(s)
}

/// The most damaged rows a warning lists.
const LISTED: usize = 5;

/// The checksum saved after a case's sweep row in the progress file: the SHA-256 of the job's
/// content hash (the scenario as loaded, the program's version, the shard: the case's inputs)
/// and of the row's fields, so that a row edited, moved to another sweep or written by another
/// version does not verify and its case is computed again.
pub(super) fn row_check(hash: &str, record: &[String]) -> String {
    let mut h = Sha256::new();
    h.update(hash.as_bytes());
    for f in record {
        h.update((f.len() as u64).to_le_bytes());
        h.update(f.as_bytes());
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// A progress file's line for `record`: its fields, then its [`row_check`].
fn progress_line(hash: &str, record: &[String]) -> Result<Vec<u8>> {
    let mut fields = record.to_vec();
    fields.push(row_check(hash, record));
    csv_line(&fields)
}

/// How a sweep's saved rows are checked: for a case index and a row, `None` when the sweep has
/// no such case, else what is wrong with the row (`Some(Ok(()))`: nothing).
pub(super) type RowCheck<'a> =
    &'a dyn Fn(usize, &[String]) -> Option<std::result::Result<(), String>>;

/// The case and sweep row of a whole progress line's `fields` (the row, then its checksum),
/// or what is wrong with them.
fn saved_row(
    mut fields: Vec<String>,
    check_row: RowCheck,
    hash: &str,
) -> std::result::Result<(usize, Vec<String>), String> {
    let not_a_case = |fields: &[String]| {
        format!(
            "column `case`: expected a case of this sweep, got \"{}\"",
            printable(fields.first().map_or("", |f| f.as_str()))
        )
    };
    let Some(index) = fields.first().and_then(|f| f.parse::<usize>().ok()) else {
        return Err(not_a_case(&fields));
    };
    let check = match fields.len() == SWEEP_HEADER.len() + 1 {
        true => fields.pop(),
        false => None,
    };
    match check_row(index, &fields) {
        None => return Err(not_a_case(&fields)),
        Some(Err(p)) => return Err(format!("case {index}: {p}")),
        Some(Ok(())) => {}
    }
    if check.as_deref() != Some(row_check(hash, &fields).as_str()) {
        return Err(format!(
            "case {index}: expected the row's checksum after it, got {} (the row was edited, or \
             saved by another version)",
            check.map_or("none".to_string(), |k| format!("\"{}\"", printable(&k)))
        ));
    }
    Ok((index, fields))
}

/// The finished cases in `csv`'s progress file (case index -> row) among `cases`, when the file
/// belongs to this `hash` (else none, silently: it is of other content). The last row cut short
/// by a kill (no line end) counts for nothing; every whole row is checked as this sweep writes
/// it (`check_row`) and against its checksum ([`row_check`]), and those that are not
/// (edited, of no case here, unreadable) are left out, their cases computed again, and named
/// in the warning returned.
pub(super) fn read_progress(
    csv: &Path,
    hash: &str,
    check_row: RowCheck,
) -> (BTreeMap<usize, Vec<String>>, Option<String>) {
    let mut done = BTreeMap::new();
    let path = progress_path(csv);
    let Ok(bytes) = crate::io::input::read_bytes(&path) else {
        return (done, None);
    };
    let Some(k) = bytes.iter().position(|&b| b == b'\n') else {
        return (done, None);
    };
    if bytes[..k].strip_prefix(b"hash ") != Some(hash.as_bytes()) {
        return (done, None);
    }
    let rest = &bytes[k + 1..];
    let whole = &rest[..rest.iter().rposition(|&b| b == b'\n').map_or(0, |k| k + 1)];
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_reader(whole);
    let mut damaged = Vec::new();
    for rec in rdr.byte_records() {
        let (line, problem) = match rec {
            Err(e) => {
                let line = e.position().map_or(0, |p| p.line() as usize + 1);
                (line, format!("unreadable: {e}"))
            }
            Ok(rec) => {
                let line = rec.position().map_or(0, |p| p.line() as usize + 1);
                let fields: Option<Vec<String>> = rec
                    .iter()
                    .map(|f| std::str::from_utf8(f).ok().map(str::to_string))
                    .collect();
                let Some(fields) = fields else {
                    damaged.push((line, "not UTF-8 text".to_string()));
                    continue;
                };
                match saved_row(fields, check_row, hash) {
                    Err(problem) => (line, problem),
                    Ok((index, row)) => {
                        done.insert(index, row);
                        continue;
                    }
                }
            }
        };
        damaged.push((line, problem));
    }
    if damaged.is_empty() {
        return (done, None);
    }
    let mut listed: Vec<String> = damaged
        .iter()
        .take(LISTED)
        .map(|(line, p)| format!("line {line}: {p}"))
        .collect();
    if damaged.len() > LISTED {
        listed.push(format!("and {} more", damaged.len() - LISTED));
    }
    let warning = format!(
        "{}: {} damaged row(s) not taken, their cases computed again ({})",
        path.display(),
        damaged.len(),
        listed.join("; ")
    );
    (done, Some(warning))
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
        bytes.extend(progress_line(&job.hash, r).ok()?);
    }
    write_atomic(&path, &bytes).ok()?;
    let f = std::fs::OpenOptions::new().append(true).open(&path).ok()?;
    Some(std::sync::Mutex::new(f))
}

/// Appends a finished case's row, with its checksum for the job's content `hash`, to the
/// progress file (one write, so a kill leaves whole rows and at most one torn last row, which
/// is ignored on reading).
pub(super) fn append_progress(
    file: &std::sync::Mutex<std::fs::File>,
    hash: &str,
    record: &[String],
) {
    use std::io::Write;
    if let (Ok(line), Ok(mut f)) = (progress_line(hash, record), file.lock()) {
        let _ = f.write_all(&line);
    }
}
