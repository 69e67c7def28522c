//! The byte link a relay driver talks over: a serial port (always with a timeout: serialport's
//! default is 0 ms), any other reader/writer (tests), or nothing at all for a dry run, where
//! writes are only recorded and reads return `None`. Every frame written is recorded so the replay
//! can print and log exactly what went on the wire.

use super::{BoardKind, RelayError};
pub use crate::serial::Port;
use std::io::{ErrorKind, Read, Write};
use std::time::{Duration, Instant};

/// The default time to wait for a board's reply.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_millis(1000);

/// A link to a board (or a dry run).
pub struct Link {
    port: Option<Box<dyn Port>>,
    name: String,
    timeout: Duration,
    sent: Vec<Vec<u8>>,
}

impl Link {
    /// Opens a serial port, 8N1, no flow control, with `timeout` for every read and write.
    ///
    /// # Errors
    ///
    /// [`RelayError::Open`] naming the port, when it cannot be opened.
    #[cfg(feature = "hardware")]
    pub fn open_serial(path: &str, baud: u32, timeout: Duration) -> Result<Link, RelayError> {
        let port = crate::serial::open_8n1(path, baud, timeout).map_err(|e| RelayError::Open {
            port: path.to_string(),
            message: e.to_string(),
        })?;
        Ok(Link::from_port(Box::new(port), path, timeout))
    }

    /// Wraps an already open port. With a `serialport` port, set its timeout before: a read
    /// must not block for ever.
    pub fn from_port(port: Box<dyn Port>, name: &str, timeout: Duration) -> Link {
        Link {
            port: Some(port),
            name: name.to_string(),
            timeout,
            sent: Vec::new(),
        }
    }

    /// A link that sends nowhere: frames are recorded, reads give `None`.
    pub fn dry_run() -> Link {
        Link {
            port: None,
            name: "<dry run>".into(),
            timeout: DEFAULT_TIMEOUT,
            sent: Vec::new(),
        }
    }

    pub fn is_dry_run(&self) -> bool {
        self.port.is_none()
    }

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

    /// Writes one frame completely and waits until it has left (drain).
    pub fn send(&mut self, frame: &[u8]) -> Result<(), RelayError> {
        self.sent.push(frame.to_vec());
        let Some(port) = self.port.as_mut() else {
            return Ok(());
        };
        if let Err(e) = port.write_all(frame) {
            return Err(self.io_err("writing", e));
        }
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
        let Some(port) = self.port.as_mut() else {
            return Ok(None);
        };
        let deadline = Instant::now() + timeout;
        let mut got = Vec::new();
        let mut buf = [0u8; 64];
        while !done(&got) {
            if got.len() >= max || Instant::now() >= deadline {
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
                Err(e) if e.kind() == ErrorKind::TimedOut || e.kind() == ErrorKind::WouldBlock => {}
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
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
