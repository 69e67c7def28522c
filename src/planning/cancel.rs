//! Abandoning a computation from another thread: a [`Cancel`] token that the closed loop on the
//! hardware hands to the planners and the sensor, so that a replan or a reading can be given up
//! the moment the coils must go off (a signal, the on-time limit). The planners look at it
//! before each batch of settles and, once it is set, settle nothing more: what they return then
//! is of no use and is thrown away. A token that is never set changes no result, bit for bit.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A cancellation token: clones share one flag; [`Cancel::never`] has none.
#[derive(Debug, Clone, Default)]
pub struct Cancel(Option<Arc<AtomicBool>>);

impl Cancel {
    /// A token that can never be set (what every computation outside the hardware loop has).
    pub fn never() -> Cancel {
        Cancel(None)
    }

    /// A fresh token, not set.
    pub fn new() -> Cancel {
        Cancel(Some(Arc::new(AtomicBool::new(false))))
    }

    /// Sets the token: every holder of a clone gives up at its next look.
    pub fn cancel(&self) {
        if let Some(flag) = &self.0 {
            flag.store(true, Ordering::SeqCst);
        }
    }

    /// Whether the token was set.
    pub fn is_cancelled(&self) -> bool {
        self.0.as_ref().is_some_and(|f| f.load(Ordering::SeqCst))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clones_share_the_flag_and_never_is_never_set() {
        let c = Cancel::new();
        let d = c.clone();
        assert!(!d.is_cancelled());
        c.cancel();
        assert!(d.is_cancelled());
        let n = Cancel::never();
        n.cancel();
        assert!(!n.is_cancelled());
    }
}
