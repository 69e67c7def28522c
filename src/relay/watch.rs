//! The one clock every coil deadline runs on while a replay waits on a board. The runner owns
//! the deadlines (it switches the coils: see `replay/runner.rs`); every link it drives holds this
//! watch and gives up a wait for a board's reply (or a blocked write) as soon as a signal
//! arrives or the earliest coil deadline passes, whatever the board's own `timeout_ms`. The
//! runner then switches every other board off and stops, naming the board that did not
//! answer. The all-off that ends a replay is never cut: its waits run their full timeout.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// No deadline (no coil on).
const NONE: u64 = u64::MAX;

/// What ended a wait early.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cut {
    /// A signal (Ctrl-C, SIGTERM, SIGHUP): the stop flag.
    Stop,
    /// A coil reached its guard (its on-time limit less the guard's margin).
    Deadline,
}

/// The stop flag and the earliest coil deadline, shared by the runner and its links.
#[derive(Debug)]
pub struct Watch {
    stop: Arc<AtomicBool>,
    origin: Instant,
    /// The earliest coil deadline, microseconds after `origin` ([`NONE`]: no coil on).
    deadline_us: AtomicU64,
    /// Set while the runner switches everything off: nothing cuts those waits.
    closing: AtomicBool,
}

impl Watch {
    /// A watch on `stop`, its deadlines counted from `origin` (the runner's start).
    pub fn new(stop: Arc<AtomicBool>, origin: Instant) -> Watch {
        Watch {
            stop,
            origin,
            deadline_us: AtomicU64::new(NONE),
            closing: AtomicBool::new(false),
        }
    }

    /// Sets the earliest coil deadline, as a time after the origin (`None`: no coil on).
    pub fn set_deadline(&self, at: Option<Duration>) {
        let us = at.map_or(NONE, |d| u64::try_from(d.as_micros()).unwrap_or(NONE - 1));
        self.deadline_us.store(us, Ordering::SeqCst);
    }

    /// The earliest coil deadline, as a time after the origin.
    pub fn deadline(&self) -> Option<Duration> {
        match self.deadline_us.load(Ordering::SeqCst) {
            NONE => None,
            us => Some(Duration::from_micros(us)),
        }
    }

    /// Marks the all-off (`true`) during which no wait is cut, and its end.
    pub fn set_closing(&self, closing: bool) {
        self.closing.store(closing, Ordering::SeqCst);
    }

    /// Whether a wait must end now: a signal, or the earliest coil deadline passed (never
    /// during the all-off).
    pub fn cut(&self) -> Option<Cut> {
        if self.closing.load(Ordering::SeqCst) {
            return None;
        }
        if self.stop.load(Ordering::SeqCst) {
            return Some(Cut::Stop);
        }
        match self.deadline() {
            Some(d) if self.origin.elapsed() >= d => Some(Cut::Deadline),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wait_is_cut_by_the_stop_flag_or_a_passed_deadline_but_not_while_closing() {
        let stop = Arc::new(AtomicBool::new(false));
        let w = Watch::new(stop.clone(), Instant::now());
        assert_eq!(w.cut(), None);
        w.set_deadline(Some(Duration::from_secs(3600)));
        assert_eq!(w.cut(), None);
        assert_eq!(w.deadline(), Some(Duration::from_secs(3600)));
        w.set_deadline(Some(Duration::ZERO));
        assert_eq!(w.cut(), Some(Cut::Deadline));
        w.set_closing(true);
        assert_eq!(w.cut(), None);
        w.set_closing(false);
        w.set_deadline(None);
        assert_eq!(w.deadline(), None);
        stop.store(true, Ordering::SeqCst);
        assert_eq!(w.cut(), Some(Cut::Stop));
    }
}
