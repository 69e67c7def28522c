//! `examples/hardware_check.rs`, the wiring check a lab runs once, against boards played on
//! pseudo-terminals: every coil on and off in turn (read back where the board can), the table,
//! the limits of a replay refused before any byte, and every coil off at the end, on a
//! mismatch and on a signal.

use crate::common::relay_support::*;
use crate::example;
use spherestep::relay::RelayError;
use spherestep::Error;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Runs the check as its `main` does (the ports opened by their paths), with `stop` as the
/// signal flag: its result and what it printed.
fn check(sc: &Path, args: &[&str], stop: Arc<AtomicBool>) -> (Result<(), Error>, String) {
    let mut all = vec![sc.display().to_string()];
    all.extend(args.iter().map(|a| a.to_string()));
    let mut out = Vec::new();
    let r = example::check(&all, stop, &mut out);
    (r, String::from_utf8_lossy(&out).into_owned())
}

/// The table's lines (from its head on).
fn table(text: &str) -> Vec<&str> {
    text.lines()
        .skip_while(|l| !l.starts_with(" coil board channel"))
        .collect()
}

/// Modbus requests: coil `ch` (1-based) switched, and the coils read back (16 channels).
fn modbus_set(ch: u8, on: bool) -> Vec<u8> {
    let mut f = vec![0x01, 0x05, 0x00, ch - 1, if on { 0xFF } else { 0x00 }, 0x00];
    let c = spherestep::relay::modbus::crc16(&f);
    f.extend(c);
    f
}

const MODBUS_READ: [u8; 8] = [0x01, 0x01, 0x00, 0x00, 0x00, 0x10, 0x3D, 0xC6];
const MODBUS_ALL_OFF: [u8; 11] = [
    0x01, 0x0F, 0x00, 0x00, 0x00, 0x10, 0x02, 0x00, 0x00, 0xE2, 0x20,
];

#[test]
fn every_coil_on_and_off_read_back_then_all_off() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let sc = scenario(dir.path(), "board = \"modbus\"");
    let (board, computer) = pty();
    let mut expected = vec![MODBUS_ALL_OFF.to_vec()];
    for ch in [1, 2] {
        for on in [true, false] {
            expected.push(modbus_set(ch, on));
            expected.push(MODBUS_READ.to_vec());
        }
    }
    expected.push(MODBUS_ALL_OFF.to_vec());
    let slave = modbus_slave(board, expected.len(), |_| Act::Answer);
    let port = path_of(&computer);
    let args = ["--port", &port, "--coils", "0,1", "--on-ms", "20"];
    let (r, text) = check(&sc, &args, Arc::new(AtomicBool::new(false)));
    let (got, _board) = slave.join().unwrap();
    r.unwrap();
    assert_eq!(got, expected);
    assert_eq!(
        table(&text),
        [
            " coil board channel  on         off",
            "    0     0       1  read back  read back",
            "    1     0       2  read back  read back",
        ],
        "{text}"
    );
    assert!(
        text.contains("done: 4 step(s) replayed; all coils off"),
        "{text}"
    );
}

#[test]
fn a_board_without_read_back_checks_every_mapped_coil_unverified() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    // two channels: coils 0 and 1 are driven, the stator's other 14 are not
    let sc = scenario(dir.path(), "board = \"lcus\"\nchannels = 2");
    let (board, computer) = pty();
    let mut expected = lcus_all_off(2);
    expected.extend([0xA0, 0x01, 0x01, 0xA2, 0xA0, 0x01, 0x00, 0xA1]);
    expected.extend([0xA0, 0x02, 0x01, 0xA3, 0xA0, 0x02, 0x00, 0xA2]);
    expected.extend(lcus_all_off(2));
    let listener = listen(board, expected.len());
    let port = path_of(&computer);
    let (r, text) = check(
        &sc,
        &["--port", &port, "--on-ms", "20"],
        Arc::new(AtomicBool::new(false)),
    );
    let (got, mut board) = listener.join().unwrap();
    r.unwrap();
    assert_eq!(got, expected);
    assert!(leftover(&mut board).is_empty());
    assert_eq!(
        table(&text)[1..],
        [
            "    0     0       1  sent       sent",
            "    1     0       2  sent       sent",
        ],
        "{text}"
    );
}

#[test]
fn a_relay_that_reads_back_wrong_stops_the_check_with_all_off() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let sc = scenario(dir.path(), "board = \"modbus\"");
    let (board, computer) = pty();
    // request 2, the first read back, reports channels 1 and 2 on instead of 1
    let slave = modbus_slave(
        board,
        4,
        |k| if k == 2 { Act::Lie(0b11) } else { Act::Answer },
    );
    let port = path_of(&computer);
    let args = ["--port", &port, "--coils", "0,1", "--on-ms", "20"];
    let (r, text) = check(&sc, &args, Arc::new(AtomicBool::new(false)));
    let (got, _board) = slave.join().unwrap();
    let e = r.unwrap_err();
    assert!(
        matches!(relay(&e).root(), RelayError::Mismatch { step: 0, .. }),
        "{e}"
    );
    assert_eq!(got[3], MODBUS_ALL_OFF);
    assert_eq!(
        table(&text)[1..],
        [
            "    0     0       1  STOPPED    -",
            "    1     0       2  -          -",
        ],
        "{text}"
    );
}

#[test]
fn a_signal_while_a_coil_is_on_switches_everything_off() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let sc = scenario(dir.path(), "board = \"lcus\"\nchannels = 2");
    let (mut board, computer) = pty();
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    // the board end signals once it has seen the all-off and coil 0 on (the check then dwells
    // 5 s with it on), then reads the all-off the signal brings
    let far = std::thread::spawn(move || {
        let first = read_n(&mut board, 8 + 4);
        flag.store(true, Ordering::SeqCst);
        let last = read_n(&mut board, 8);
        (first, last, board)
    });
    let port = path_of(&computer);
    let (r, text) = check(&sc, &["--port", &port, "--on-ms", "5000"], stop);
    let (first, last, mut board) = far.join().unwrap();
    let e = r.unwrap_err();
    assert!(matches!(relay(&e).root(), RelayError::Interrupted), "{e}");
    assert_eq!(first[8..], [0xA0, 0x01, 0x01, 0xA2]);
    assert_eq!(last, lcus_all_off(2));
    assert!(leftover(&mut board).is_empty());
    assert_eq!(table(&text)[1], "    0     0       1  STOPPED    -");
}

#[test]
fn the_limits_of_a_replay_are_checked_before_any_byte() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let sc = scenario(dir.path(), "board = \"lcus\"\nmax_on_time_s = 1");
    let (mut board, computer) = pty();
    let port = path_of(&computer);
    let (r, text) = check(
        &sc,
        &["--port", &port, "--on-ms", "1500"],
        Arc::new(AtomicBool::new(false)),
    );
    let e = r.unwrap_err();
    assert!(matches!(relay(&e), RelayError::OnTooLong { .. }), "{e}");
    assert!(
        e.worded(&example::CheckFlags)
            .contains("give a shorter --on-ms"),
        "{}",
        e.worded(&example::CheckFlags)
    );
    assert!(text.is_empty(), "{text}");
    assert!(leftover(&mut board).is_empty());
    // and a check with no coil is not one
    let (r, _) = check(
        &sc,
        &["--port", &port, "--on-ms", "0"],
        Arc::new(AtomicBool::new(false)),
    );
    assert!(r
        .unwrap_err()
        .worded(&example::CheckFlags)
        .starts_with("argument --on-ms: expected how long each coil of a wiring check stays on"),);
}
