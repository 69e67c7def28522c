//! Each relay board played on the far end of a pseudo-terminal: the exact bytes of a short
//! plan, in order, ending with every channel off; read-back and its mismatch.

use crate::common::relay_support;

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
    let _one = crate::one_at_a_time();
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
    let _one = crate::one_at_a_time();
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
    let _one = crate::one_at_a_time();
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
    let _one = crate::one_at_a_time();
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
    let _one = crate::one_at_a_time();
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
        matches!(relay(&e).root(), RelayError::Mismatch { step: 0, .. }),
        "{e}"
    );
    let msg = flagged(&e);
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
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let sc = scenario(dir.path(), "board = \"lcus\"");
    let mut opts = options(&short_plan(dir.path()), &sc);
    opts.verify = true;
    let (mut board, computer) = pty();
    let (r, _) = run(&opts, link(&computer));
    assert!(matches!(
        r.as_ref().map_err(relay),
        Err(RelayError::NoReadBack { .. })
    ));
    assert!(leftover(&mut board).is_empty());
}

/// Two 8-channel LCUS boards, coils 0 and 2 on board 0 (channels 1, 2), coils 1 and 3 on
/// board 1 (channels 1, 8).
const TWO_LCUS: &str = "max_coils_on = 4
[[relay.boards]]
port = \"/dev/ttyUSB0\"
board = \"lcus\"
channels = 8
[[relay.boards]]
port = \"/dev/ttyUSB1\"
board = \"lcus\"
channels = 8
[relay.map]
0 = \"0:1\"
1 = \"1:1\"
2 = \"0:2\"
3 = \"1:8\"";

/// The listing rows (without time) of the short plan on `TWO_LCUS`, in the order sent.
fn two_lcus_rows() -> Vec<String> {
    let all_off = |b: usize| -> Vec<String> {
        (1..=8u8)
            .map(|c| format!("    - all-off      -     {b}       -  A0 0{c} 00 A{c}"))
            .collect()
    };
    let mut want: Vec<String> = [all_off(0), all_off(1)].concat();
    want.extend(
        [
            "    0 on           0     0       1  A0 01 01 A2",
            "    0 on           1     1       1  A0 01 01 A2",
            "    0 dwell 0 ms",
            "    1 on           2     0       2  A0 02 01 A3",
            "    1 off          1     1       1  A0 01 00 A1",
            "    1 dwell 0 ms",
            "    2 on           3     1       8  A0 08 01 A9",
            "    2 off          0     0       1  A0 01 00 A1",
            "    2 dwell 0 ms",
        ]
        .map(String::from),
    );
    want.extend([all_off(0), all_off(1)].concat());
    want
}

#[test]
fn two_lcus_boards_exact_frames_on_each() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("replay.csv");
    let mut opts = options(&short_plan(dir.path()), &scenario(dir.path(), TWO_LCUS));
    opts.log = Some(log.clone());
    let mut expected0 = lcus_all_off(8);
    expected0.extend([
        0xA0, 0x01, 0x01, 0xA2, // step 0: coil 0 on (channel 1)
        0xA0, 0x02, 0x01, 0xA3, // step 1: coil 2 on (channel 2)
        0xA0, 0x01, 0x00, 0xA1, // step 2: coil 0 off (channel 1)
    ]);
    expected0.extend(lcus_all_off(8));
    let mut expected1 = lcus_all_off(8);
    expected1.extend([
        0xA0, 0x01, 0x01, 0xA2, // step 0: coil 1 on (channel 1)
        0xA0, 0x01, 0x00, 0xA1, // step 1: coil 1 off (channel 1)
        0xA0, 0x08, 0x01, 0xA9, // step 2: coil 3 on (channel 8)
    ]);
    expected1.extend(lcus_all_off(8));
    let (board0, computer0) = pty();
    let (board1, computer1) = pty();
    let listener0 = listen(board0, expected0.len());
    let listener1 = listen(board1, expected1.len());
    let links = vec![named_link(&computer0), named_link(&computer1)];
    let (r, text) = run_on(&opts, links, None);
    let (got0, mut board0) = listener0.join().unwrap();
    let (got1, mut board1) = listener1.join().unwrap();
    let summary = r.unwrap();
    assert_eq!(summary.steps_done, 3);
    assert_eq!(got0, expected0);
    assert_eq!(got1, expected1);
    assert!(leftover(&mut board0).is_empty());
    assert!(leftover(&mut board1).is_empty());

    // The listing: which board each frame went to, in the order sent (make-before-break
    // across boards: step 1 switches board 0 on before board 1 off).
    let (p0, p1) = (path_of(&computer0), path_of(&computer1));
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("replaying on 2 boards: make-before-break, realtime, steps 0..=2")
    );
    let board_line = |i, p: &str| format!("  board {i} ({p}): lcus board, 8 channels, 9600 baud");
    assert_eq!(lines.next(), Some(board_line(0, &p0).as_str()));
    assert_eq!(lines.next(), Some(board_line(1, &p1).as_str()));
    assert_eq!(
        lines.next(),
        Some("      t_s  step action    coil board channel  bytes")
    );
    assert_eq!(rows_without_time(&text), two_lcus_rows(), "{text}");
    assert!(
        text.ends_with("done: 3 step(s) replayed; all coils off\n"),
        "{text}"
    );

    // The log has a board column.
    let csv = std::fs::read_to_string(&log).unwrap();
    assert!(
        csv.starts_with("t_s,step,action,coil,board,channel,bytes\n"),
        "{csv}"
    );
    assert!(csv.contains(",0,on,1,1,1,A0 01 01 A2\n"), "{csv}");
    assert!(csv.contains(",2,on,3,1,8,A0 08 01 A9\n"), "{csv}");
    assert!(csv.contains(",,all-off,,1,,A0 08 00 A8\n"), "{csv}");
    assert!(csv.contains(",2,done,,,,\n"), "{csv}");
    assert_eq!(spherestep::commands::replay::resume_step(&log).unwrap(), 3);
}

#[test]
fn two_boards_dry_run_lays_the_coils_onto_the_boards_in_order() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    // No map: coils 0, 1 on board 0 (2 channels), coils 2..=5 on board 1 (4 channels).
    let sc = scenario(
        dir.path(),
        "[[relay.boards]]\nport = \"/dev/ttyUSB0\"\nboard = \"lcus\"\nchannels = 2\n[[relay.boards]]\nboard = \"kmtronic\"\nchannels = 4",
    );
    let plan = plan(dir.path(), "p.csv", &["0:10;2:11", "2:11;5:12"], 0.1);
    let mut opts = options(&plan, &sc);
    opts.dry_run = true;
    opts.dwell_ms = None;
    let mut out = Vec::new();
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let summary = spherestep::commands::replay::run(&opts, stop, None, &mut out).unwrap();
    assert_eq!(summary.steps_done, 2);
    let text = String::from_utf8(out).unwrap();
    let expected = "\
dry run (no port opened): 2 boards, make-before-break, realtime, steps 0..=1
  board 0 (/dev/ttyUSB0): lcus board, 2 channels, 9600 baud
  board 1 (no port): kmtronic board, 4 channels, 9600 baud
      t_s  step action    coil board channel  bytes
    0.000     - all-off      -     0       -  A0 01 00 A1
    0.000     - all-off      -     0       -  A0 02 00 A2
    0.000     - all-off      -     1       -  FF 01 00
    0.000     - all-off      -     1       -  FF 02 00
    0.000     - all-off      -     1       -  FF 03 00
    0.000     - all-off      -     1       -  FF 04 00
    0.000     0 on           0     0       1  A0 01 01 A2
    0.000     0 on           2     1       1  FF 01 01
    0.000     0 dwell 200 ms
    0.200     1 on           5     1       4  FF 04 01
    0.200     1 off          0     0       1  A0 01 00 A1
    0.200     1 dwell 200 ms
    0.400     - all-off      -     0       -  A0 01 00 A1
    0.400     - all-off      -     0       -  A0 02 00 A2
    0.400     - all-off      -     1       -  FF 01 00
    0.400     - all-off      -     1       -  FF 02 00
    0.400     - all-off      -     1       -  FF 03 00
    0.400     - all-off      -     1       -  FF 04 00
done: 2 step(s) replayed; all coils off
";
    assert_eq!(text, expected);
    // A coil past the boards' six channels is refused before anything is sent.
    let far = plan_with(dir.path(), &["0:10;6:11"]);
    let mut opts = options(&far, &sc);
    opts.dry_run = true;
    let e = flagged(&spherestep::commands::replay::prepare(&opts).unwrap_err());
    assert!(
        e.contains("coil 6, which lies past the 6 channels of the 2 boards"),
        "{e}"
    );
}

fn plan_with(dir: &std::path::Path, steps: &[&str]) -> std::path::PathBuf {
    plan(dir, "far.csv", steps, 0.1)
}

/// `replay::prepare` on a scenario with this `[relay]` body (and `ports` as --port): the error.
fn refusal(relay: &str, ports: &[&str]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let mut opts = options(&short_plan(dir.path()), &scenario(dir.path(), relay));
    opts.ports = ports.iter().map(|p| p.to_string()).collect();
    let e = flagged(&spherestep::commands::replay::prepare(&opts).unwrap_err());
    assert!(
        e.contains("scenario.toml") || e.starts_with("argument"),
        "{e}"
    );
    e
}

#[test]
fn multi_board_maps_and_arguments_are_refused_by_name() {
    let _one = crate::one_at_a_time();
    let two = "[[relay.boards]]\nboard = \"lcus\"\n[[relay.boards]]\nboard = \"lcus\"\n";
    // A board that is not listed.
    let e = refusal(&format!("{two}[relay.map]\n3 = \"2:1\""), &[]);
    assert!(
        e.contains("field `relay.map.3`")
            && e.contains("a board of [[relay.boards]], 0..=1 (2 listed), got board 2"),
        "{e}"
    );
    // A channel past the board's count.
    let e = refusal(&format!("{two}[relay.map]\n3 = \"1:9\""), &[]);
    assert!(
        e.contains("field `relay.map.3`")
            && e.contains("a channel of board 1 (lcus board, channels 1..=8), got channel 9"),
        "{e}"
    );
    // Two coils on one board channel.
    let e = refusal(&format!("{two}[relay.map]\n2 = \"0:5\"\n3 = \"0:5\""), &[]);
    assert!(
        e.contains("field `relay.map.3`")
            && e.contains("a board channel no other coil uses, got \"0:5\"")
            && e.contains("already coil 2's"),
        "{e}"
    );
    // Not a board:channel.
    let e = refusal(&format!("{two}[relay.map]\n3 = 4"), &[]);
    assert!(
        e.contains("field `relay.map.3`") && e.contains("\"board:channel\""),
        "{e}"
    );
    // Both forms at once.
    let e = refusal(&format!("board = \"lcus\"\n{two}"), &[]);
    assert!(
        e.contains("field `relay.board`")
            && e.contains("no top-level `board` next to [[relay.boards]]"),
        "{e}"
    );
    let e = refusal(&format!("channels = 8\n{two}"), &[]);
    assert!(e.contains("field `relay.channels`"), "{e}");
    // A channel count the board type cannot have.
    let e = refusal(
        "[[relay.boards]]\nboard = \"lcus\"\n[[relay.boards]]\nboard = \"lcus\"\nchannels = 16",
        &[],
    );
    assert!(
        e.contains("field `relay.boards[1].channels`") && e.contains("1..=8 for a lcus board"),
        "{e}"
    );
    // --port once per board, or not at all.
    let e = refusal(two, &["/dev/a", "/dev/b", "/dev/c"]);
    assert!(
        e.contains("argument --port")
            && e.contains("once per board of [[relay.boards]], in list order (2 boards)")
            && e.contains("got 3"),
        "{e}"
    );
    let e = refusal(two, &["/dev/a"]);
    assert!(e.contains("argument --port") && e.contains("got 1"), "{e}");
    let e = refusal(two, &["/dev/a", "/dev/a"]);
    assert!(
        e.contains("argument --port") && e.contains("/dev/a for boards 0 and 1"),
        "{e}"
    );
    // The single-board form takes one --port.
    let e = refusal("board = \"lcus\"", &["/dev/a", "/dev/b"]);
    assert!(
        e.contains("argument --port") && e.contains("one serial device for the board, got 2"),
        "{e}"
    );
}

#[test]
fn board_and_baud_options_are_refused_with_several_boards() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let sc = scenario(dir.path(), TWO_LCUS);
    let mut opts = options(&short_plan(dir.path()), &sc);
    opts.board = Some(spherestep::relay::BoardKind::Numato);
    let e = flagged(&spherestep::commands::replay::prepare(&opts).unwrap_err());
    assert!(
        e.contains("argument --board: expected none with [[relay.boards]]")
            && e.contains("single-board form only"),
        "{e}"
    );
    opts.board = None;
    opts.baud = Some(19200);
    let e = flagged(&spherestep::commands::replay::prepare(&opts).unwrap_err());
    assert!(
        e.contains("argument --baud: expected none with [[relay.boards]]")
            && e.contains("each entry gives its board's `baud`"),
        "{e}"
    );
    // The limits count the coils of all boards: coils 0 (board 0) and 1, 3 (board 1) on at
    // once are three.
    let plan = plan(dir.path(), "p.csv", &["0:1;1:2;3:3"], 0.1);
    let sc = scenario(
        dir.path(),
        &TWO_LCUS.replace("max_coils_on = 4", "max_coils_on = 2"),
    );
    let e = spherestep::commands::replay::prepare(&options(&plan, &sc)).unwrap_err();
    assert!(
        matches!(
            relay(&e),
            RelayError::TooManyOn {
                step: 0,
                count: 3,
                max: 2,
                ..
            }
        ),
        "{e}"
    );
}

const ALL_OFF_16: [u8; 11] = [
    0x01, 0x0F, 0x00, 0x00, 0x00, 0x10, 0x02, 0x00, 0x00, 0xE2, 0x20,
];

/// A Modbus board (16 channels) and a 4-channel LCUS board; coils 0, 2 on the Modbus
/// board's channels 1, 2, coils 1, 3 on the LCUS board's channels 1, 2.
const MODBUS_AND_LCUS: &str = "[[relay.boards]]
board = \"modbus\"
[[relay.boards]]
board = \"lcus\"
channels = 4
[relay.map]
0 = \"0:1\"
1 = \"1:1\"
2 = \"0:2\"
3 = \"1:2\"";

#[test]
fn verify_reads_back_the_boards_that_can() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let sc = scenario(dir.path(), MODBUS_AND_LCUS);
    let mut opts = options(&short_plan(dir.path()), &sc);
    opts.verify = true;
    let read = vec![0x01, 0x01, 0x00, 0x00, 0x00, 0x10, 0x3D, 0xC6];
    let expected0: Vec<Vec<u8>> = vec![
        ALL_OFF_16.to_vec(),
        vec![0x01, 0x05, 0x00, 0x00, 0xFF, 0x00, 0x8C, 0x3A], // step 0: channel 1 on
        read.clone(),
        vec![0x01, 0x05, 0x00, 0x01, 0xFF, 0x00, 0xDD, 0xFA], // step 1: channel 2 on
        read.clone(),
        vec![0x01, 0x05, 0x00, 0x00, 0x00, 0x00, 0xCD, 0xCA], // step 2: channel 1 off
        read,
        ALL_OFF_16.to_vec(),
    ];
    let mut expected1 = lcus_all_off(4);
    expected1.extend([
        0xA0, 0x01, 0x01, 0xA2, // step 0: channel 1 on
        0xA0, 0x01, 0x00, 0xA1, // step 1: channel 1 off
        0xA0, 0x02, 0x01, 0xA3, // step 2: channel 2 on
    ]);
    expected1.extend(lcus_all_off(4));
    let (board0, computer0) = pty();
    let (board1, computer1) = pty();
    let slave = modbus_slave(board0, expected0.len(), |_| Act::Answer);
    let listener = listen(board1, expected1.len());
    let links = vec![named_link(&computer0), named_link(&computer1)];
    let (r, text) = run_on(&opts, links, None);
    let (got0, _board0) = slave.join().unwrap();
    let (got1, mut board1) = listener.join().unwrap();
    r.unwrap();
    assert_eq!(got0, expected0);
    assert_eq!(got1, expected1);
    assert!(leftover(&mut board1).is_empty());
    assert!(
        text.contains("lcus board, 4 channels, 9600 baud, not read back"),
        "{text}"
    );
    assert!(
        text.contains("modbus board, 16 channels, 9600 baud, slave 1, read back"),
        "{text}"
    );
    assert!(
        text.contains("    0 read         -     0       -  01 01 00 00 00 10 3D C6"),
        "{text}"
    );
}

#[test]
fn verify_mismatch_on_one_board_names_it_and_switches_both_off() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let sc = scenario(dir.path(), MODBUS_AND_LCUS);
    let mut opts = options(&short_plan(dir.path()), &sc);
    opts.verify = true;
    // The first read (request 2) reports channels 1 and 3 on instead of 1.
    let (board0, computer0) = pty();
    let (board1, computer1) = pty();
    let slave = modbus_slave(board0, 4, |k| {
        if k == 2 {
            Act::Lie(0b101)
        } else {
            Act::Answer
        }
    });
    let mut expected1 = lcus_all_off(4);
    expected1.extend([0xA0, 0x01, 0x01, 0xA2]);
    expected1.extend(lcus_all_off(4));
    let listener = listen(board1, expected1.len());
    let links = vec![named_link(&computer0), named_link(&computer1)];
    let (r, _) = run_on(&opts, links, None);
    let (got0, _board0) = slave.join().unwrap();
    let (got1, mut board1) = listener.join().unwrap();
    let e = r.unwrap_err();
    assert!(
        matches!(relay(&e).root(), RelayError::Mismatch { step: 0, .. }),
        "{e}"
    );
    let msg = flagged(&e);
    let p0 = path_of(&computer0);
    assert!(
        msg.contains(&format!(
            "board 0 ({p0}): verify after step 0: expected channels on [1], the board reports [1, 3]"
        )) && msg.contains("all coils switched off; resume with --from-step 0"),
        "{msg}"
    );
    assert_eq!(got0[3], ALL_OFF_16);
    assert_eq!(got1, expected1);
    assert!(leftover(&mut board1).is_empty());
}
