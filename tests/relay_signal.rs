//! The built binary replaying on a pseudo-terminal in realtime mode: SIGINT (Ctrl-C) or
//! SIGTERM in the middle of a dwell sends every channel off and exits non-zero. The test
//! signals only after the board end has seen step 0's frames, so nothing depends on timing.

mod relay_support;

use relay_support::*;
use std::process::{Command, Stdio};

fn all_off_lcus() -> Vec<u8> {
    vec![
        0xA0, 0x01, 0x00, 0xA1, 0xA0, 0x02, 0x00, 0xA2, 0xA0, 0x03, 0x00, 0xA3, 0xA0, 0x04, 0x00,
        0xA4, 0xA0, 0x05, 0x00, 0xA5, 0xA0, 0x06, 0x00, 0xA6, 0xA0, 0x07, 0x00, 0xA7, 0xA0, 0x08,
        0x00, 0xA8,
    ]
}

fn signal_mid_replay(signal: &str) {
    let dir = tempfile::tempdir().unwrap();
    let plan = short_plan(dir.path());
    // A dwell of ten minutes: the signal always arrives inside it.
    let sc = scenario(dir.path(), "max_on_time_s = 100000");
    let (mut board, computer) = pty();
    let child = Command::new(env!("CARGO_BIN_EXE_spherestep"))
        .arg("replay")
        .arg(&plan)
        .arg(&sc)
        .args(["--port", &path_of(&computer)])
        .args([
            "--board",
            "lcus",
            "--mode",
            "realtime",
            "--dwell-ms",
            "600000",
        ])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut start = all_off_lcus();
    start.extend([0xA0, 0x01, 0x01, 0xA2, 0xA0, 0x02, 0x01, 0xA3]);
    let got = read_n(&mut board, start.len());
    assert_eq!(got, start);
    let killed = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let got = read_n(&mut board, 32);
    assert_eq!(got, all_off_lcus());
    let out = child.wait_with_output().unwrap();
    assert!(!out.status.success(), "exit status {:?}", out.status);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr
            .contains("interrupted by a signal; all coils switched off; resume with --from-step 0"),
        "{stderr}"
    );
    assert!(leftover(&mut board).is_empty());
    drop(computer);
}

#[test]
fn sigint_mid_replay_sends_all_off_and_fails() {
    signal_mid_replay("-INT");
}

#[test]
fn sigterm_mid_replay_sends_all_off_and_fails() {
    signal_mid_replay("-TERM");
}

#[test]
fn dry_run_prints_frames_without_a_port() {
    let dir = tempfile::tempdir().unwrap();
    let plan = short_plan(dir.path());
    let out = Command::new(env!("CARGO_BIN_EXE_spherestep"))
        .args(["replay", "--board", "kmtronic", "--dry-run"])
        .arg(&plan)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.starts_with("dry run (no port opened): kmtronic board, 8 channels, 9600 baud"),
        "{text}"
    );
    // Step 1 at 0.200 s (0.1 s x 1.5 = 0.15 s, raised to the 200 ms floor): on before off.
    let on = text
        .find("    0.200     1 on           2       3  FF 03 01")
        .expect(&text);
    let off = text
        .find("    0.200     1 off          1       2  FF 02 00")
        .expect(&text);
    assert!(on < off, "{text}");
    assert!(
        text.contains("done: 3 step(s) replayed; all coils off"),
        "{text}"
    );
}

#[test]
fn sigterm_mid_replay_on_two_boards_sends_all_off_to_both() {
    let dir = tempfile::tempdir().unwrap();
    // Coil 0 on board 0 channel 1, coil 8 on board 1 channel 1 (laid in order); the ports in
    // the scenario are replaced by --port, once per board.
    let plan = plan(dir.path(), "p.csv", &["0:10;8:11", "8:11"], 0.1);
    let sc = scenario(
        dir.path(),
        "max_on_time_s = 100000\n[[relay.boards]]\nport = \"/dev/nonexistent-0\"\nboard = \"lcus\"\n[[relay.boards]]\nport = \"/dev/nonexistent-1\"\nboard = \"lcus\"",
    );
    let (mut board0, computer0) = pty();
    let (mut board1, computer1) = pty();
    let child = Command::new(env!("CARGO_BIN_EXE_spherestep"))
        .arg("replay")
        .arg(&plan)
        .arg(&sc)
        .args(["--port", &path_of(&computer0)])
        .args(["--port", &path_of(&computer1)])
        .args(["--mode", "realtime", "--dwell-ms", "600000"])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut start = all_off_lcus();
    start.extend([0xA0, 0x01, 0x01, 0xA2]);
    assert_eq!(read_n(&mut board0, start.len()), start);
    assert_eq!(read_n(&mut board1, start.len()), start);
    let killed = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    assert_eq!(read_n(&mut board0, 32), all_off_lcus());
    assert_eq!(read_n(&mut board1, 32), all_off_lcus());
    let out = child.wait_with_output().unwrap();
    assert!(!out.status.success(), "exit status {:?}", out.status);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr
            .contains("interrupted by a signal; all coils switched off; resume with --from-step 0"),
        "{stderr}"
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.starts_with("replaying on 2 boards: make-before-break, realtime, steps 0..=1"),
        "{stdout}"
    );
    assert!(leftover(&mut board0).is_empty());
    assert!(leftover(&mut board1).is_empty());
    drop((computer0, computer1));
}
