//! The built binary replaying on a pseudo-terminal in realtime mode: SIGINT (Ctrl-C) or
//! SIGTERM in the middle of a dwell sends every channel off and exits non-zero. The test
//! signals only after the board end has seen step 0's frames, so nothing depends on timing.
//! In a closed loop the signal also acts while the replay waits for the sensor or replans:
//! every coil off within a second of it.

use crate::common::relay_support;

use relay_support::*;
use serialport::{SerialPort, TTYPort};
use std::io::{Read, Write};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

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
    let sc = scenario(dir.path(), "max_on_time_s = 86400");
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
    interrupted(child);
    assert!(leftover(&mut board).is_empty());
    drop(computer);
}

/// The output of a replay stopped by a signal: it failed, saying every coil was switched off
/// and to resume from step 0.
fn interrupted(child: std::process::Child) -> std::process::Output {
    let out = child.wait_with_output().unwrap();
    assert!(!out.status.success(), "exit status {:?}", out.status);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr
            .contains("interrupted by a signal; all coils switched off; resume with --from-step 0"),
        "{stderr}"
    );
    out
}

#[test]
fn sigint_mid_replay_sends_all_off_and_fails() {
    let _one = crate::one_at_a_time();
    signal_mid_replay("-INT");
}

#[test]
fn sigterm_mid_replay_sends_all_off_and_fails() {
    let _one = crate::one_at_a_time();
    signal_mid_replay("-TERM");
}

/// `q` in step mode quits on purpose: every coil off, where to resume said, and
/// exit status 0 (quitting is what was asked, not a failure).
#[test]
fn q_in_step_mode_quits_with_all_off_and_status_zero() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let plan = short_plan(dir.path());
    let sc = scenario(dir.path(), "board = \"lcus\"\nchannels = 4");
    let (mut board, computer) = pty();
    let mut child = Command::new(env!("CARGO_BIN_EXE_spherestep"))
        .arg("replay")
        .arg(&plan)
        .arg(&sc)
        .args(["--port", &path_of(&computer), "--mode", "step"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Enter for step 0, then q before step 1
    let mut stdin = child.stdin.take().unwrap();
    stdin.write_all(b"\nq\n").unwrap();
    drop(stdin);
    let off: Vec<u8> = (1..=4u8).flat_map(|c| [0xA0, c, 0x00, 0xA0 + c]).collect();
    let mut expected = off.clone();
    expected.extend([0xA0, 0x01, 0x01, 0xA2, 0xA0, 0x02, 0x01, 0xA3]);
    expected.extend(&off);
    assert_eq!(read_n(&mut board, expected.len()), expected);
    let out = child.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("quit before step 1; all coils off; resume with --from-step 1"),
        "{stdout}"
    );
    assert!(leftover(&mut board).is_empty());
    drop(computer);
}

#[test]
fn dry_run_prints_frames_without_a_port() {
    let _one = crate::one_at_a_time();
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
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    // Coil 0 on board 0 channel 1, coil 8 on board 1 channel 1 (laid in order); the ports in
    // the scenario are replaced by --port, once per board.
    let plan = plan(dir.path(), "p.csv", &["0:10;8:11", "8:11"], 0.1);
    let sc = scenario(
        dir.path(),
        "max_on_time_s = 86400\n[[relay.boards]]\nport = \"/dev/nonexistent-0\"\nboard = \"lcus\"\n[[relay.boards]]\nport = \"/dev/nonexistent-1\"\nboard = \"lcus\"",
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
    let out = interrupted(child);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.starts_with("replaying on 2 boards: make-before-break, realtime, steps 0..=1"),
        "{stdout}"
    );
    assert!(leftover(&mut board0).is_empty());
    assert!(leftover(&mut board1).is_empty());
    drop((computer0, computer1));
}

/// An LCUS board's far end for the closed-loop signal tests: every frame with when it had
/// arrived, shared while it records, until `done`.
type Frames = Arc<Mutex<Vec<(Instant, [u8; 4])>>>;

fn recorder(mut port: TTYPort, done: Arc<AtomicBool>) -> (Frames, JoinHandle<()>) {
    let frames: Frames = Arc::default();
    let theirs = frames.clone();
    let h = std::thread::spawn(move || {
        port.set_timeout(Duration::from_millis(5)).unwrap();
        let (mut got, mut buf, start) = (Vec::new(), [0u8; 64], Instant::now());
        while !done.load(Ordering::SeqCst) && start.elapsed() < GUARD {
            if let Ok(n) = port.read(&mut buf) {
                let at = Instant::now();
                let old = got.len() / 4;
                got.extend_from_slice(&buf[..n]);
                let mut f = theirs.lock().unwrap();
                for c in got.chunks_exact(4).skip(old) {
                    f.push((at, [c[0], c[1], c[2], c[3]]));
                }
            }
        }
    });
    (frames, h)
}

/// What the sensor's far end does during a closed-loop replay.
#[derive(Clone, Copy)]
enum Sensor {
    /// Answers the tare, then never again (the replay waits for it).
    Silent,
    /// Reads 180 degrees about Z whatever the ball does (the replay replans, for seconds).
    Far,
}

/// The built binary closing the loop on two LCUS boards (broad wells, 10 s of on-time) and a
/// quat-csv sensor that is `sensor`; `signal` sent 0.4 s after step 0's coils went on: every
/// coil off on both boards within a second of it, and the program ended soon after.
fn signal_mid_closed_loop(signal: &str, sensor: Sensor) {
    let dir = tempfile::tempdir().unwrap();
    let plan = broad_plan(dir.path(), "scenarios/broad-wells.toml");
    let map = dir.path().join("boards.toml");
    std::fs::write(
        &map,
        "max_on_time_s = 10\nmax_coils_on = 8\n[[boards]]\nboard = \"lcus\"\n[[boards]]\nboard = \"lcus\"\n",
    )
    .unwrap();
    let done = Arc::new(AtomicBool::new(false));
    let (b0, c0) = pty();
    let (b1, c1) = pty();
    let (mut s_far, s_near) = pty();
    // the silent sensor answers the tare (taken before any coil is switched), then falls
    // silent once step 0's coils are on
    let switched = Arc::new(AtomicBool::new(false));
    let printer = {
        let done = done.clone();
        let switched = switched.clone();
        std::thread::spawn(move || {
            while !done.load(Ordering::SeqCst) {
                let talks = match sensor {
                    Sensor::Far => true,
                    Sensor::Silent => !switched.load(Ordering::SeqCst),
                };
                if talks {
                    let _ = s_far.write_all(b"0,0,0,1\r\n");
                }
                std::thread::sleep(Duration::from_millis(10));
            }
        })
    };
    let (f0, h0) = recorder(b0, done.clone());
    let (f1, h1) = recorder(b1, done.clone());
    let child = Command::new(env!("CARGO_BIN_EXE_spherestep"))
        .arg("replay")
        .arg(&plan)
        .arg("scenarios/broad-wells.toml")
        .arg("--map")
        .arg(&map)
        .args(["--port", &path_of(&c0), "--port", &path_of(&c1)])
        .args(["--sensor", &path_of(&s_near), "--sensor-format", "quat-csv"])
        .args(["--sensor-timeout-ms", "5000", "--dwell-ms", "50"])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let on = |f: &Frames| f.lock().unwrap().iter().any(|(_, b)| b[2] == 1);
    let start = Instant::now();
    while !(on(&f0) || on(&f1)) {
        assert!(start.elapsed() < GUARD, "step 0 never switched");
        std::thread::sleep(Duration::from_millis(5));
    }
    switched.store(true, Ordering::SeqCst);
    std::thread::sleep(Duration::from_millis(400));
    let sent = Instant::now();
    let killed = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let out = child.wait_with_output().unwrap();
    let exited = Instant::now();
    done.store(true, Ordering::SeqCst);
    h0.join().unwrap();
    h1.join().unwrap();
    printer.join().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "exit status {:?}", out.status);
    assert!(
        stderr.contains("interrupted by a signal"),
        "{stderr}\n{stdout}"
    );
    for f in [&f0, &f1] {
        let f = f.lock().unwrap();
        // the first all-off after the signal arrived within a second of it ...
        let first_off = f
            .iter()
            .position(|(t, _)| *t >= sent)
            .unwrap_or_else(|| panic!("nothing after the signal\n{stdout}"));
        let after: Vec<u8> = f[first_off..].iter().flat_map(|(_, b)| *b).collect();
        assert!(after.starts_with(&all_off_lcus()), "{after:02X?}\n{stdout}");
        let took = f[first_off].0 - sent;
        assert!(
            took < Duration::from_secs(1),
            "all off {took:?} after the signal\n{stdout}"
        );
        // ... and nothing was switched on after it
        assert!(after.chunks_exact(4).all(|c| c[2] == 0), "{after:02X?}");
    }
    let took = exited - sent;
    assert!(
        took < Duration::from_secs(2),
        "exited {took:?} after the signal\n{stdout}"
    );
    drop((c0, c1, s_near));
}

#[test]
fn sigint_while_the_closed_loop_waits_for_a_silent_sensor_switches_off_at_once() {
    let _one = crate::one_at_a_time();
    signal_mid_closed_loop("-INT", Sensor::Silent);
}

#[test]
fn sigterm_while_the_closed_loop_replans_switches_off_at_once() {
    let _one = crate::one_at_a_time();
    signal_mid_closed_loop("-TERM", Sensor::Far);
}
