//! The real-time integration tests, one binary: the serial code against relay boards and
//! sensors played on the far ends of pseudo-terminals, the built binary signalled mid-replay,
//! and the virtual motor driven by `replay` (`cargo test --release --test rig relay_safety::`).
//! Every wait has a deadline; they need Linux or another Unix with pseudo-terminals (see
//! TESTING.md). The shared harness is `tests/common/relay_support.rs`.

#![cfg(unix)]

#[path = "../common/mod.rs"]
mod common;

mod relay_boards;
mod relay_closed_loop;
mod relay_safety;
mod relay_signal;
mod sensor_mount;
mod sensors;
mod virtual_closed_loop;
mod virtual_motor;
