//! The byte link a relay driver talks over: a serial port (always with a timeout: serialport's
//! default is 0 ms), any other reader/writer (tests), or nothing at all for a dry run, where
//! writes are only recorded and reads return `None`. Every frame written is recorded so the replay
//! can print and log exactly what went on the wire.
//!
//! A serial port is opened with a short read timeout (`PORT_POLL`) and the board's reply
//! timeout is kept here, so that a wait for a reply (or a blocked write) also ends as soon as
//! the replay's [`Watch`] says so: a signal, or a coil at its guard. After a wait cut short, the
//! board's late reply is read and dropped before the next frame goes out.

use super::watch::{Cut, Watch};
use super::{BoardKind, RelayError};
pub use crate::serial::Port;
use std::io::{ErrorKind, Read, Write};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The default time to wait for a board's reply.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_millis(1000);

/// The read timeout a serial port is opened with: how often a wait looks at its watch.
#[cfg(feature = "hardware")]
pub const PORT_POLL: Duration = Duration::from_millis(5);

/// The longest a late reply is read and dropped before the next frame.
const DRAIN: Duration = Duration::from_millis(100);

/// A link to a board (or a dry run).
pub struct Link {
    port: Option<Box<dyn Port>>,
    name: String,
    timeout: Duration,
    sent: Vec<Vec<u8>>,
    /// The replay's watch (none: waits run their full timeout).
    watch: Option<Arc<Watch>>,
    /// A wait was cut short: a late reply may still arrive.
    stale: bool,
}

impl Link {
    /// Opens a serial port, 8N1, no flow control, waiting at most `timeout` for every reply
    /// and write (the port itself polls every `PORT_POLL`).
    ///
    /// # Errors
    ///
    /// [`RelayError::Open`] naming the port, when it cannot be opened.
    #[cfg(feature = "hardware")]
    pub fn open_serial(path: &str, baud: u32, timeout: Duration) -> Result<Link, RelayError> {
        let poll = PORT_POLL.min(timeout);
        let port = crate::serial::open_8n1(path, baud, poll).map_err(|e| RelayError::Open {
            port: path.to_string(),
            message: e.to_string(),
        })?;
        Ok(Link::from_port(Box::new(port), path, timeout))
    }

    /// Wraps an already open port. With a `serialport` port, set its timeout before: a read
    /// must not block for ever (and a short one lets the watch cut a wait at once).
    pub fn from_port(port: Box<dyn Port>, name: &str, timeout: Duration) -> Link {
        Link {
            port: Some(port),
            name: name.to_string(),
            timeout,
            sent: Vec::new(),
            watch: None,
            stale: false,
        }
    }

    /// Has every wait of this link watched by `watch` (see the module comment).
    pub fn set_watch(&mut self, watch: Arc<Watch>) {
        self.watch = Some(watch);
    }

    /// `Err` when the watch says the wait that began at `begun` must end: a signal, or a coil
    /// at its guard; the link then expects a late reply.
    fn check_cut(&mut self, op: &'static str, begun: Instant) -> Result<(), RelayError> {
        let Some(cut) = self.watch.as_ref().and_then(|w| w.cut()) else {
            return Ok(());
        };
        self.stale = true;
        Err(match cut {
            Cut::Stop => RelayError::Interrupted,
            Cut::Deadline => RelayError::WaitCut {
                port: self.name.clone(),
                op,
                waited: begun.elapsed(),
                timeout: self.timeout,
            },
        })
    }

    /// Reads and drops what a board sends late (after a wait was cut), for at most [`DRAIN`]
    /// and until the port has nothing more.
    fn drain_stale(&mut self) {
        if !std::mem::take(&mut self.stale) {
            return;
        }
        let Some(port) = self.port.as_mut() else {
            return;
        };
        let begun = Instant::now();
        let mut buf = [0u8; 64];
        while begun.elapsed() < DRAIN {
            match port.read(&mut buf) {
                Ok(n) if n > 0 => {}
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                _ => return,
            }
        }
    }

    /// A link that sends nowhere: frames are recorded, reads give `None`.
    pub fn dry_run() -> Link {
        Link {
            port: None,
            name: "<dry run>".into(),
            timeout: DEFAULT_TIMEOUT,
            sent: Vec::new(),
            watch: None,
            stale: false,
        }
    }

    /// Whether the link only records (a dry run: no port is open).
    pub fn is_dry_run(&self) -> bool {
        self.port.is_none()
    }

    /// The link's name in messages: the name it was opened with (its serial device), or `<dry
    /// run>`.
    pub fn name(&self) -> &str {
        &self.name
    }

    fn io_err(&self, op: &'static str, e: std::io::Error) -> RelayError {
        match e.kind() {
            ErrorKind::BrokenPipe | ErrorKind::UnexpectedEof | ErrorKind::ConnectionReset => {
                RelayError::Closed {
                    port: self.name.clone(),
                    op,
                }
            }
            _ if e.raw_os_error() == Some(5) => RelayError::Closed {
                // EIO: a serial device unplugged, or a pseudo-terminal whose other end closed.
                port: self.name.clone(),
                op,
            },
            _ => RelayError::Port {
                port: self.name.clone(),
                op,
                source: e,
            },
        }
    }

    /// Writes one frame completely (within the timeout, watched) and waits until it has left
    /// (drain).
    pub fn send(&mut self, frame: &[u8]) -> Result<(), RelayError> {
        self.sent.push(frame.to_vec());
        if self.port.is_none() {
            return Ok(());
        }
        self.drain_stale();
        let begun = Instant::now();
        let mut rest = frame;
        while !rest.is_empty() {
            self.check_cut("writing", begun)?;
            let Some(port) = self.port.as_mut() else {
                return Ok(());
            };
            match port.write(rest) {
                Ok(0) => {
                    return Err(RelayError::Closed {
                        port: self.name.clone(),
                        op: "writing",
                    })
                }
                Ok(n) => rest = &rest[n..],
                Err(e) if waiting(&e) && begun.elapsed() < self.timeout => {}
                Err(e) => return Err(self.io_err("writing", e)),
            }
        }
        let Some(port) = self.port.as_mut() else {
            return Ok(());
        };
        // serialport reports a failed drain as a bare "flush failed"; unplugging (or closing
        // the far end) during it is the usual cause.
        port.flush()
            .map_err(|e| self.io_err("draining the written frame", e))
    }

    /// Reads until `done(bytes so far)` says the reply is complete, or the timeout passes.
    fn recv_while(
        &mut self,
        board: BoardKind,
        max: usize,
        done: impl Fn(&[u8]) -> bool,
    ) -> Result<Option<Vec<u8>>, RelayError> {
        let timeout = self.timeout;
        if self.port.is_none() {
            return Ok(None);
        }
        let begun = Instant::now();
        let mut got = Vec::new();
        let mut buf = [0u8; 64];
        while !done(&got) {
            self.check_cut("waiting for a reply", begun)?;
            let Some(port) = self.port.as_mut() else {
                return Ok(None);
            };
            if got.len() >= max || begun.elapsed() >= timeout {
                return Err(RelayError::NoReply {
                    board,
                    port: self.name.clone(),
                    timeout,
                    got: got.len(),
                    partial: got,
                });
            }
            // Read one byte at a time once close to the end, never past the reply.
            let want = buf.len().min(max - got.len());
            match port.read(&mut buf[..want]) {
                Ok(0) => {
                    return Err(RelayError::Closed {
                        port: self.name.clone(),
                        op: "waiting for a reply",
                    })
                }
                Ok(n) => got.extend_from_slice(&buf[..n]),
                Err(e) if waiting(&e) => {}
                Err(e) => return Err(self.io_err("waiting for a reply", e)),
            }
        }
        Ok(Some(got))
    }

    /// Reads exactly `n` bytes; `None` in a dry run.
    pub fn recv_exact(
        &mut self,
        board: BoardKind,
        n: usize,
    ) -> Result<Option<Vec<u8>>, RelayError> {
        self.recv_while(board, n, |b| b.len() >= n)
    }

    /// Reads until the byte `end` arrives (included), at most `max` bytes; `None` in a dry run.
    pub fn recv_until(
        &mut self,
        board: BoardKind,
        end: u8,
        max: usize,
    ) -> Result<Option<Vec<u8>>, RelayError> {
        self.recv_while(board, max, |b| b.last() == Some(&end))
    }

    /// The frames sent since the last call.
    pub fn take_sent(&mut self) -> Vec<Vec<u8>> {
        std::mem::take(&mut self.sent)
    }
}

/// An error that only means "nothing yet": the port's poll ran out, or a signal interrupted it
/// (the wait goes on, watched).
fn waiting(e: &std::io::Error) -> bool {
    matches!(
        e.kind(),
        ErrorKind::TimedOut | ErrorKind::WouldBlock | ErrorKind::Interrupted
    )
}
