//! Each relay board played on the far end of a pseudo-terminal: the exact bytes of a short
//! plan, in order, ending with every channel off; read-back and its mismatch.

mod relay_support;

use relay_support::*;
use spherestep::relay::RelayError;

fn all_off_lcus() -> Vec<u8> {
    vec![
        0xA0, 0x01, 0x00, 0xA1, 0xA0, 0x02, 0x00, 0xA2, 0xA0, 0x03, 0x00, 0xA3, 0xA0, 0x04, 0x00,
        0xA4, 0xA0, 0x05, 0x00, 0xA5, 0xA0, 0x06, 0x00, 0xA6, 0xA0, 0x07, 0x00, 0xA7, 0xA0, 0x08,
        0x00, 0xA8,
    ]
}

#[test]
fn lcus_exact_bytes_make_before_break() {
    let dir = tempfile::tempdir().unwrap();
    let opts = options(
        &short_plan(dir.path()),
        &scenario(dir.path(), "board = \"lcus\""),
    );
    let mut expected = all_off_lcus();
    expected.extend([
        // step 0: coils 0 and 1 on (channels 1, 2)
        0xA0, 0x01, 0x01, 0xA2, 0xA0, 0x02, 0x01, 0xA3, //
        // step 1: coil 2 on (channel 3) before coil 1 off (channel 2)
        0xA0, 0x03, 0x01, 0xA4, 0xA0, 0x02, 0x00, 0xA2, //
        // step 2: coil 3 on (channel 4) before coil 0 off (channel 1)
        0xA0, 0x04, 0x01, 0xA5, 0xA0, 0x01, 0x00, 0xA1,
    ]);
    expected.extend(all_off_lcus());
    let (board, computer) = pty();
    let listener = listen(board, expected.len());
    let (r, text) = run(&opts, link(&computer));
    let (got, mut board) = listener.join().unwrap();
    let summary = r.unwrap();
    assert_eq!(summary.steps_done, 3);
    assert_eq!(summary.next_step, 3);
    assert_eq!(got, expected);
    assert!(leftover(&mut board).is_empty());
    assert!(text.contains("A0 03 01 A4"), "{text}");
}

#[test]
fn kmtronic_exact_bytes_break_before_make() {
    let dir = tempfile::tempdir().unwrap();
    let sc = scenario(
        dir.path(),
        "board = \"kmtronic\"\nchannels = 4\norder = \"break-before-make\"",
    );
    let opts = options(&short_plan(dir.path()), &sc);
    let off4 = [
        0xFF, 0x01, 0x00, 0xFF, 0x02, 0x00, 0xFF, 0x03, 0x00, 0xFF, 0x04, 0x00,
    ];
    let mut expected = off4.to_vec();
    expected.extend([
        0xFF, 0x01, 0x01, 0xFF, 0x02, 0x01, // step 0
        0xFF, 0x02, 0x00, 0xFF, 0x03, 0x01, // step 1: off first
        0xFF, 0x01, 0x00, 0xFF, 0x04, 0x01, // step 2: off first
    ]);
    expected.extend(off4);
    let (board, computer) = pty();
    let listener = listen(board, expected.len());
    let (r, _) = run(&opts, link(&computer));
    let (got, mut board) = listener.join().unwrap();
    r.unwrap();
    assert_eq!(got, expected);
    assert!(leftover(&mut board).is_empty());
}

#[test]
fn numato_exact_commands_with_verify_and_letters() {
    let dir = tempfile::tempdir().unwrap();
    // Coil 3 on channel 12: relay index 11, written `B`.
    let sc = scenario(
        dir.path(),
        "board = \"numato\"\n[relay.map]\n0 = 1\n1 = 2\n2 = 3\n3 = 12",
    );
    let mut opts = options(&short_plan(dir.path()), &sc);
    opts.verify = true;
    let expected = [
        "relay writeall 0000\r",
        "relay on 0\r",
        "relay on 1\r",
        "relay readall\r",
        "relay on 2\r",
        "relay off 1\r",
        "relay readall\r",
        "relay on B\r",
        "relay off 0\r",
        "relay readall\r",
        "relay writeall 0000\r",
    ];
    let (board, computer) = pty();
    let module = numato_module(board, expected.len());
    let (r, _) = run(&opts, link(&computer));
    let (got, _board) = module.join().unwrap();
    r.unwrap();
    assert_eq!(got, expected);
}

#[test]
fn modbus_exact_frames_with_verify() {
    let dir = tempfile::tempdir().unwrap();
    let sc = scenario(dir.path(), "board = \"modbus\"\nslave_address = 1");
    let mut opts = options(&short_plan(dir.path()), &sc);
    opts.verify = true;
    let all_off = vec![
        0x01, 0x0F, 0x00, 0x00, 0x00, 0x10, 0x02, 0x00, 0x00, 0xE2, 0x20,
    ];
    let read = vec![0x01, 0x01, 0x00, 0x00, 0x00, 0x10, 0x3D, 0xC6];
    let expected: Vec<Vec<u8>> = vec![
        all_off.clone(),
        vec![0x01, 0x05, 0x00, 0x00, 0xFF, 0x00, 0x8C, 0x3A], // channel 1 on
        vec![0x01, 0x05, 0x00, 0x01, 0xFF, 0x00, 0xDD, 0xFA], // channel 2 on
        read.clone(),
        vec![0x01, 0x05, 0x00, 0x02, 0xFF, 0x00, 0x2D, 0xFA], // channel 3 on
        vec![0x01, 0x05, 0x00, 0x01, 0x00, 0x00, 0x9C, 0x0A], // channel 2 off
        read.clone(),
        vec![0x01, 0x05, 0x00, 0x03, 0xFF, 0x00, 0x7C, 0x3A], // channel 4 on
        vec![0x01, 0x05, 0x00, 0x00, 0x00, 0x00, 0xCD, 0xCA], // channel 1 off
        read,
        all_off,
    ];
    let (board, computer) = pty();
    let slave = modbus_slave(board, expected.len(), |_| Act::Answer);
    let (r, _) = run(&opts, link(&computer));
    let (got, _board) = slave.join().unwrap();
    r.unwrap();
    assert_eq!(got, expected);
}

#[test]
fn verify_mismatch_stops_with_all_off() {
    let dir = tempfile::tempdir().unwrap();
    let sc = scenario(dir.path(), "board = \"modbus\"");
    let mut opts = options(&short_plan(dir.path()), &sc);
    opts.verify = true;
    // The first read (request 3) reports channels 1, 2 and 3 on instead of 1 and 2.
    let (board, computer) = pty();
    let slave = modbus_slave(
        board,
        5,
        |k| if k == 3 { Act::Lie(0b111) } else { Act::Answer },
    );
    let (r, _) = run(&opts, link(&computer));
    let (got, _board) = slave.join().unwrap();
    let e = r.unwrap_err();
    assert!(
        matches!(e.root(), RelayError::Mismatch { step: 0, .. }),
        "{e}"
    );
    let msg = e.to_string();
    assert!(
        msg.contains("expected channels on [1, 2]") && msg.contains("[1, 2, 3]"),
        "{msg}"
    );
    assert!(msg.contains("resume with --from-step 0"), "{msg}");
    // The request after the failed read is the all-off.
    assert_eq!(
        got[4],
        [0x01, 0x0F, 0x00, 0x00, 0x00, 0x10, 0x02, 0x00, 0x00, 0xE2, 0x20]
    );
}

#[test]
fn verify_refused_where_the_board_cannot_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let sc = scenario(dir.path(), "board = \"lcus\"");
    let mut opts = options(&short_plan(dir.path()), &sc);
    opts.verify = true;
    let (mut board, computer) = pty();
    let (r, _) = run(&opts, link(&computer));
    assert!(matches!(r, Err(RelayError::NoReadBack { .. })));
    assert!(leftover(&mut board).is_empty());
}
