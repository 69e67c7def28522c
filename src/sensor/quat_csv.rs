//! The quat-csv sensor: a microcontroller (an Arduino with an IMU library) printing one line
//! `w,x,y,z` per reading, ended by `\n` or `\r\n`, as fast as it likes.
//!
//! Freshness: a reader thread reads the port all the time and stamps each line with the
//! moment its first byte was read. [`QuatCsv::read`](super::OrientationSensor::read) skips every line whose first byte was read
//! before the call began (stale: everything buffered, and a line half received at the call),
//! skips blank lines, and decodes the next complete line; none within the timeout is
//! [`SensorError::Timeout`]. "Before the call" holds to within the reader thread's latency (it
//! reads continuously, so well under a millisecond on an idle machine). Only the last
//! [`QUEUE`] lines are kept between calls; older ones are stale anyway.
//!
//! A line is a reading when it is exactly four comma-separated finite numbers (spaces around
//! them allowed), in the order w, x, y, z, whose norm is within
//! [`NORM_TOLERANCE`](super::NORM_TOLERANCE) of 1; it is then normalised (a line of full
//! precision that is unit already, to the rounding, is kept to the bit). Anything else (or a
//! line longer than [`MAX_LINE`] bytes) is [`SensorError::Garbage`] with the line.

use super::{
    is_idle, unit_quaternion, Cancel, Ident, Port, Raw, Reading, SensorError, SensorFormat,
};
use crate::model::geometry::Orientation;
use std::collections::VecDeque;
use std::io::{ErrorKind, Read};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The longest line accepted, in bytes (line end excluded).
pub const MAX_LINE: usize = 256;
/// How many received lines are kept while nobody reads.
pub const QUEUE: usize = 64;

/// One line as received.
#[derive(Debug)]
struct Line {
    /// When its first byte was read.
    started: Instant,
    /// Without the line end.
    bytes: Vec<u8>,
    /// Cut at [`MAX_LINE`] bytes (the rest, up to the next line end, is dropped).
    overlong: bool,
}

/// Why the reader thread stopped reading.
#[derive(Debug, Clone)]
enum End {
    /// End of file: the far end closed.
    Eof,
    /// A read failed (kept as parts, to rebuild the `io::Error` for every later call).
    Failed {
        kind: ErrorKind,
        os: Option<i32>,
        text: String,
    },
}

impl End {
    fn error(&self, id: &Ident) -> SensorError {
        match self {
            End::Eof => id.closed("reading"),
            End::Failed { kind, os, text } => {
                let e = match os {
                    Some(code) => std::io::Error::from_raw_os_error(*code),
                    None => std::io::Error::new(*kind, text.clone()),
                };
                id.io_err("reading", e)
            }
        }
    }
}

#[derive(Debug, Default)]
struct Inbox {
    lines: VecDeque<Line>,
    end: Option<End>,
}

/// What the reader thread and the sensor share.
#[derive(Debug, Default)]
struct Shared {
    inbox: Mutex<Inbox>,
    arrived: Condvar,
    stop: AtomicBool,
}

impl Shared {
    /// The inbox; a panic elsewhere while holding it leaves it consistent, so poison is ignored.
    fn lock(&self) -> MutexGuard<'_, Inbox> {
        self.inbox.lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn deliver(&self, lines: Vec<Line>) {
        if lines.is_empty() {
            return;
        }
        let mut inbox = self.lock();
        for line in lines {
            if inbox.lines.len() >= QUEUE {
                inbox.lines.pop_front();
            }
            inbox.lines.push_back(line);
        }
        drop(inbox);
        self.arrived.notify_all();
    }

    fn finish(&self, end: End) {
        self.lock().end = Some(end);
        self.arrived.notify_all();
    }
}

/// Cuts the byte stream into lines.
#[derive(Debug, Default)]
struct Assembler {
    current: Vec<u8>,
    started: Option<Instant>,
    /// Dropping the rest of an overlong line.
    skipping: bool,
}

impl Assembler {
    fn push(&mut self, bytes: &[u8], at: Instant, out: &mut Vec<Line>) {
        for &b in bytes {
            if b == b'\n' {
                if !self.skipping {
                    out.push(self.take(at, false));
                }
                self.skipping = false;
                self.started = None;
                continue;
            }
            if self.skipping {
                continue;
            }
            self.started.get_or_insert(at);
            self.current.push(b);
            if self.current.len() >= MAX_LINE {
                out.push(self.take(at, true));
                self.skipping = true;
            }
        }
    }

    fn take(&mut self, at: Instant, overlong: bool) -> Line {
        let mut bytes = std::mem::take(&mut self.current);
        if !overlong && bytes.last() == Some(&b'\r') {
            bytes.pop();
        }
        Line {
            started: self.started.take().unwrap_or(at),
            bytes,
            overlong,
        }
    }
}

/// The reader thread: reads until told to stop or the port fails.
fn pump(mut port: Box<dyn Port>, shared: Arc<Shared>) {
    let mut asm = Assembler::default();
    let mut buf = [0u8; 256];
    while !shared.stop.load(Ordering::Relaxed) {
        match port.read(&mut buf) {
            Ok(0) => return shared.finish(End::Eof),
            Ok(n) => {
                let mut lines = Vec::new();
                asm.push(&buf[..n], Instant::now(), &mut lines);
                shared.deliver(lines);
            }
            Err(e) if is_idle(&e) => {}
            Err(e) => {
                return shared.finish(End::Failed {
                    kind: e.kind(),
                    os: e.raw_os_error(),
                    text: e.to_string(),
                })
            }
        }
    }
}

/// Decodes one line: `w,x,y,z`, or why it is not a reading.
pub fn parse_line(line: &str) -> Result<Orientation, String> {
    let fields: Vec<&str> = line.split(',').map(str::trim).collect();
    if fields.len() != 4 {
        return Err(format!(
            "expected 4 comma-separated numbers w,x,y,z, got {} field(s)",
            fields.len()
        ));
    }
    let mut c = [0.0; 4];
    for (k, (slot, text)) in c.iter_mut().zip(&fields).enumerate() {
        *slot = text
            .parse::<f64>()
            .map_err(|_| format!("field {} ('{text}') is not a number", k + 1))?;
    }
    unit_quaternion(c[0], c[1], c[2], c[3])
}

/// A quat-csv sensor on a port (see the module comment).
pub struct QuatCsv {
    id: Ident,
    timeout: Duration,
    shared: Arc<Shared>,
    reader: Option<JoinHandle<()>>,
    cancel: Cancel,
}

impl QuatCsv {
    /// Starts the reader thread on `port`; `timeout` bounds every [`read`](super::OrientationSensor::read).
    pub fn start(port: Box<dyn Port>, name: &str, timeout: Duration) -> Result<Self, SensorError> {
        let id = Ident {
            sensor: SensorFormat::QuatCsv,
            port: name.to_string(),
        };
        let shared = Arc::new(Shared::default());
        let theirs = Arc::clone(&shared);
        let reader = std::thread::Builder::new()
            .name(format!("quat-csv {name}"))
            .spawn(move || pump(port, theirs))
            .map_err(|e| SensorError::Io {
                sensor: id.sensor,
                port: id.port.clone(),
                op: "starting the reader thread",
                source: e,
            })?;
        Ok(QuatCsv {
            id,
            timeout,
            shared,
            reader: Some(reader),
            cancel: Cancel::never(),
        })
    }

    fn decode(&self, line: Line) -> Result<Reading, SensorError> {
        let text = String::from_utf8_lossy(&line.bytes).into_owned();
        let garbage = |reason: String| SensorError::Garbage {
            sensor: self.id.sensor,
            port: self.id.port.clone(),
            line: text.clone(),
            reason,
        };
        if line.overlong {
            return Err(garbage(format!("no line end within {MAX_LINE} bytes")));
        }
        let orientation = parse_line(&text).map_err(garbage)?;
        Ok(Reading {
            orientation,
            raw: Raw::Line(text),
        })
    }

    /// The next fresh line (see the module comment).
    fn next_fresh(&self, begun: Instant) -> Result<Line, SensorError> {
        let deadline = begun + self.timeout;
        let mut stale = 0usize;
        let mut inbox = self.shared.lock();
        loop {
            while let Some(line) = inbox.lines.pop_front() {
                if line.started < begun {
                    stale += 1;
                } else if !line.bytes.iter().all(u8::is_ascii_whitespace) {
                    return Ok(line);
                }
            }
            if let Some(end) = &inbox.end {
                return Err(end.error(&self.id));
            }
            if self.cancel.is_cancelled() {
                return Err(self.id.abandoned());
            }
            let now = Instant::now();
            if now >= deadline {
                let got = match stale {
                    0 => String::new(),
                    n => format!("only {n} line(s) from before the call, skipped as stale"),
                };
                return Err(self.id.timeout("reading", self.timeout, got));
            }
            inbox = self
                .shared
                .arrived
                .wait_timeout(inbox, (deadline - now).min(super::POLL_INTERVAL))
                .unwrap_or_else(PoisonError::into_inner)
                .0;
        }
    }
}

impl super::OrientationSensor for QuatCsv {
    fn read(&mut self) -> Result<Reading, SensorError> {
        let line = self.next_fresh(Instant::now())?;
        self.decode(line)
    }

    fn describe(&self) -> String {
        format!("quat-csv sensor on {}", self.id.port)
    }

    fn set_cancel(&mut self, cancel: Cancel) {
        self.cancel = cancel;
    }
}

impl Drop for QuatCsv {
    /// Stops the reader thread and waits for it (at most one read of the port's own timeout),
    /// so that the port is closed when the sensor is gone.
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::Relaxed);
        if let Some(reader) = self.reader.take() {
            let _ = reader.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines_of(chunks: &[&[u8]]) -> Vec<Line> {
        let mut asm = Assembler::default();
        let mut out = Vec::new();
        for c in chunks {
            asm.push(c, Instant::now(), &mut out);
        }
        out
    }

    #[test]
    fn sensor_csv_lines_are_cut_at_newlines_across_chunks() {
        let out = lines_of(&[b"1,0,0,0\r\n0.5,", b"0.5,0.5,0.5\n", b"\r\npartial"]);
        let texts: Vec<&[u8]> = out.iter().map(|l| l.bytes.as_slice()).collect();
        assert_eq!(texts, vec![&b"1,0,0,0"[..], b"0.5,0.5,0.5,0.5", b""]);
        assert!(out.iter().all(|l| !l.overlong));
    }

    #[test]
    fn sensor_csv_overlong_lines_are_cut_once() {
        let long = vec![b'7'; MAX_LINE + 40];
        let out = lines_of(&[&long, b"\n1,0,0,0\n"]);
        assert_eq!(out.len(), 2);
        assert!(out[0].overlong && out[0].bytes.len() == MAX_LINE);
        assert_eq!(out[1].bytes, b"1,0,0,0");
    }

    #[test]
    fn sensor_csv_parse_line_decodes_and_refuses() {
        let q = parse_line(" 0.5, -0.5 ,0.5,0.5").unwrap();
        assert_eq!((q.w, q.i, q.j, q.k), (0.5, -0.5, 0.5, 0.5));
        let q = parse_line("0,0,0,1.05").unwrap();
        assert!((q.k - 1.0).abs() < 1e-15 && q.w == 0.0);
        assert!(parse_line("1,0,0").unwrap_err().contains("got 3 field(s)"));
        assert!(parse_line("1,0,0,0,0").unwrap_err().contains("got 5"));
        assert!(parse_line("1,0,zero,0")
            .unwrap_err()
            .contains("field 3 ('zero')"));
        assert!(parse_line("1,0,0,nan").unwrap_err().contains("not finite"));
        assert!(parse_line("2,0,0,0").unwrap_err().contains("norm 2.0000"));
        assert!(parse_line("").is_err());
    }
}
