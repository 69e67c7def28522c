//! The real-time integration tests, one binary: the serial code against relay boards and
//! sensors played on the far ends of pseudo-terminals, the built binary signalled mid-replay,
//! and the virtual motor driven by `replay` (`cargo test --release --test rig relay_safety::`).
//! Every wait has a deadline; they need Linux or another Unix with pseudo-terminals (see
//! TESTING.md). The shared harness is `tests/common/relay_support.rs`.

#![cfg(unix)]

use std::sync::{Mutex, MutexGuard};

/// The tests of this binary run one at a time: each plays devices, a virtual motor or the
/// binary in real time, and two at once on a two-core machine starve each other's processes
/// (a board's reply late, a coil's on-time spent waiting, a sensor's line read a frame later).
/// Every test takes this first and holds it to its end; a test that failed before lets the
/// next one go on.
fn one_at_a_time() -> MutexGuard<'static, ()> {
    static ONE: Mutex<()> = Mutex::new(());
    ONE.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

#[path = "../common/mod.rs"]
mod common;

/// `examples/hardware_check.rs`, the wiring check, called as its `main` calls it.
#[path = "../../examples/hardware_check.rs"]
#[allow(dead_code)]
mod example;

mod hardware;
mod hardware_check;
mod relay_boards;
mod relay_closed_loop;
mod relay_safety;
mod relay_signal;
mod sensor_mount;
mod sensors;
mod virtual_closed_loop;
mod virtual_excitation;
mod virtual_motor;
