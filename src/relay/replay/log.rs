//! The replay's CSV log (`--log`): its header for one board or several, the check of an
//! existing file before anything is appended to it, and its rows.

use super::ports::Prepared;
use crate::relay::{RelayError, Setting, Wording};
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};

/// The replay log: `t_s,step,action,coil,channel,bytes` (with several boards
/// `t_s,step,action,coil,board,channel,bytes`), one row per frame, a `done` row when a step's
/// dwell completed and a `start` row per run; flushed after every step. A closed-loop replay's
/// log has the measurement's columns after those (`LOG_SENSOR_COLUMNS`), empty in the other
/// rows.
pub(super) struct Log {
    path: PathBuf,
    file: std::io::BufWriter<std::fs::File>,
    /// The board column is written.
    pub(super) listed: bool,
    /// How many columns a row has (shorter rows are padded with empty ones).
    columns: usize,
}

/// Which replay a log is of: its columns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum LogKind {
    Replay,
    /// With the measurement's columns (`LOG_SENSOR_COLUMNS`).
    ClosedLoop,
}

/// The log's header.
pub const LOG_HEADER: &str = "t_s,step,action,coil,channel,bytes";
/// The log's header with several boards (`[[relay.boards]]`).
pub const LOG_HEADER_BOARDS: &str = "t_s,step,action,coil,board,channel,bytes";
/// The columns a closed-loop replay's log has after the others: the measured quaternion, its
/// angle from the goal (degrees) and what the sensor sent (a line, or a frame in hex).
pub const LOG_SENSOR_COLUMNS: &str = "qw,qx,qy,qz,goal_deg,raw";

/// The log's header for one board or several (`listed`), of a replay or a closed loop.
fn log_header(listed: bool, kind: LogKind) -> String {
    let base = if listed {
        LOG_HEADER_BOARDS
    } else {
        LOG_HEADER
    };
    match kind {
        LogKind::Replay => base.to_string(),
        LogKind::ClosedLoop => format!("{base},{LOG_SENSOR_COLUMNS}"),
    }
}

/// What a `--log` path holds before the replay writes to it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct LogFile {
    /// A log with rows already (appended to, its header not written again).
    existing: bool,
    /// Its last byte is a line end (else one is written before the first row).
    ends_with_line_end: bool,
}

/// What refuses a log whose first line is `line` as a log of another kind than this replay's
/// (its `header`, of `kind`), if it is one: whose log it is and what to do.
fn other_log_kind(line: &[u8], header: &str, kind: LogKind) -> Option<String> {
    let other = [false, true]
        .into_iter()
        .flat_map(|l| {
            [
                log_header(l, LogKind::Replay),
                log_header(l, LogKind::ClosedLoop),
            ]
        })
        .find(|h| line == h.as_bytes());
    other.map(|other| {
        let why = if kind == LogKind::Replay && other.contains(LOG_SENSOR_COLUMNS) {
            "a closed-loop replay's log"
        } else if kind == LogKind::ClosedLoop && !other.contains(LOG_SENSOR_COLUMNS) {
            "a replay's log without the sensor's columns"
        } else {
            "one board / several"
        };
        format!(
            "its columns are `{other}`, this replay writes `{header}` ({why}): give another log file"
        )
    })
}

/// The longest first line read to tell whether a file is a replay log.
const LOG_FIRST_LINE_MAX: u64 = 4096;

/// Checks that the log at `path` may take this replay's rows: a new or empty file, or a log
/// whose first line is exactly this replay's header (`log_header(listed, kind)`). Anything
/// else is refused: a log of another kind (its columns would not line up), and any other file
/// (a plan, a scenario, notes: appending would corrupt it).
fn inspect_log(
    path: &Path,
    listed: bool,
    kind: LogKind,
    w: &dyn Wording,
) -> Result<LogFile, RelayError> {
    use std::io::{Read, Seek, SeekFrom};
    let err = |e| RelayError::Log {
        path: path.to_path_buf(),
        cause: e,
    };
    let refuse = |message: String| {
        err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            message,
        ))
    };
    let header = log_header(listed, kind);
    let meta = match std::fs::metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Ok(LogFile {
                existing: false,
                ends_with_line_end: true,
            })
        }
        Err(e) => return Err(err(e)),
        Ok(m) => m,
    };
    if meta.is_dir() {
        return Err(refuse(
            "expected a file for the replay log, got a folder: give another log file".into(),
        ));
    }
    if meta.len() == 0 {
        return Ok(LogFile {
            existing: false,
            ends_with_line_end: true,
        });
    }
    let mut f = std::fs::File::open(path).map_err(err)?;
    let mut first = Vec::new();
    std::io::BufReader::new((&mut f).take(LOG_FIRST_LINE_MAX))
        .read_until(b'\n', &mut first)
        .map_err(err)?;
    let line = first.strip_suffix(b"\n").unwrap_or(&first);
    if line == header.as_bytes() {
        let mut last = [0u8];
        f.seek(SeekFrom::End(-1))
            .and_then(|_| f.read_exact(&mut last))
            .map_err(err)?;
        return Ok(LogFile {
            existing: true,
            ends_with_line_end: last[0] == b'\n',
        });
    }
    if let Some(message) = other_log_kind(line, &header, kind) {
        return Err(refuse(message));
    }
    let text = crate::text::printable(&String::from_utf8_lossy(line));
    let shown = match text.char_indices().nth(80) {
        Some((k, _)) => format!("{}...", &text[..k]),
        None => text,
    };
    Err(refuse(format!(
        "expected an empty or new file, or a replay log whose first line is exactly `{header}`; \
         its first line is `{shown}`, so it is not a replay log and is not appended to: give \
         another {} file",
        w.name(Setting::Log)
    )))
}

/// Checks the replay's `--log` (when given) before any port is opened: see `Log::open`.
/// `closed_loop`: the log of a closed-loop replay (with the sensor's columns).
pub fn check_log(prep: &Prepared, closed_loop: bool) -> Result<(), RelayError> {
    let kind = match closed_loop {
        true => LogKind::ClosedLoop,
        false => LogKind::Replay,
    };
    match &prep.drive.log {
        Some(p) => inspect_log(p, prep.listed(), kind, prep.wording).map(|_| ()),
        None => Ok(()),
    }
}

impl Log {
    /// Opens (appends to) the log, after `inspect_log`: a new or empty file gets the header;
    /// a log of this replay's header is appended to, on a line of its own; anything else (a
    /// log of another kind, any other file) is refused.
    pub(super) fn open(
        path: &Path,
        listed: bool,
        kind: LogKind,
        w: &dyn Wording,
    ) -> Result<Log, RelayError> {
        let err = |e| RelayError::Log {
            path: path.to_path_buf(),
            cause: e,
        };
        let header = log_header(listed, kind);
        let found = inspect_log(path, listed, kind, w)?;
        let file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .map_err(err)?;
        let mut log = Log {
            path: path.to_path_buf(),
            file: std::io::BufWriter::new(file),
            listed,
            columns: header.split(',').count(),
        };
        if !found.existing {
            writeln!(log.file, "{header}").map_err(err)?;
        } else if !found.ends_with_line_end {
            writeln!(log.file).map_err(err)?;
        }
        Ok(log)
    }

    /// One row: `cols`, then empty columns up to the header's count.
    pub(super) fn row(&mut self, cols: &[&str]) -> Result<(), RelayError> {
        let pad = self.columns.saturating_sub(cols.len());
        writeln!(self.file, "{}{}", cols.join(","), ",".repeat(pad)).map_err(|e| RelayError::Log {
            path: self.path.clone(),
            cause: e,
        })
    }

    /// A closed loop's row of a measurement (`sensor`) or of the tare (`tare`): time, step,
    /// action, the frame's columns empty, then `LOG_SENSOR_COLUMNS`: the quaternion `q` (w, x,
    /// y, z), its angle from the goal (`goal_deg`, empty for none) and what the sensor sent
    /// (`raw`, quoted).
    pub(super) fn measurement(
        &mut self,
        t: &str,
        step: &str,
        action: &str,
        q: [f64; 4],
        goal_deg: Option<f64>,
        raw: &str,
    ) -> Result<(), RelayError> {
        let q = q.map(|c| c.to_string());
        let goal = goal_deg.map(|d| format!("{d:.4}")).unwrap_or_default();
        let raw = csv_field(raw);
        let frame = log_header(self.listed, LogKind::Replay).split(',').count();
        let mut cols = vec![t, step, action];
        cols.resize(frame, "");
        cols.extend(q.iter().map(String::as_str));
        cols.extend([goal.as_str(), raw.as_str()]);
        self.row(&cols)
    }

    /// A `start` or `done` row (or another marker): time, step, action, the other columns
    /// empty.
    pub(super) fn marker(&mut self, t: &str, step: &str, action: &str) -> Result<(), RelayError> {
        self.row(&[t, step, action])
    }

    pub(super) fn flush(&mut self) -> Result<(), RelayError> {
        self.file.flush().map_err(|e| RelayError::Log {
            path: self.path.clone(),
            cause: e,
        })
    }
}

/// A CSV field: quoted, its quotes doubled.
fn csv_field(s: &str) -> String {
    format!("\"{}\"", s.replace('"', "\"\""))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_csv_fields_are_quoted() {
        assert_eq!(csv_field("1,0,0,0"), "\"1,0,0,0\"");
        assert_eq!(csv_field("a\"b"), "\"a\"\"b\"");
    }
}
