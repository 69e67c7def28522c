//! Safety of the hardware replay on a pseudo-terminal: limits refused before any byte is sent,
//! the board end closing mid-replay gives a clear error (not a hang), and `--from-step`
//! resumes where the log stopped.

use crate::common::relay_support;

use relay_support::*;
use spherestep::commands::replay;
use spherestep::relay::replay::{execute, Mode};
use spherestep::relay::RelayError;

#[test]
fn too_many_coils_refused_before_any_byte() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let plan = plan(dir.path(), "p.csv", &["0:1;1:2", "0:1;1:2;2:3"], 0.1);
    let sc = scenario(dir.path(), "board = \"lcus\"\nmax_coils_on = 2");
    let (mut board, computer) = pty();
    let (r, _) = run(&options(&plan, &sc), link(&computer));
    let e = r.unwrap_err();
    assert!(
        matches!(
            relay(&e),
            RelayError::TooManyOn {
                step: 1,
                count: 3,
                max: 2,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("coils 0, 1, 2"), "{e}");
    assert!(leftover(&mut board).is_empty(), "bytes were sent");
}

#[test]
fn make_before_break_counts_the_overlap() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let plan = short_plan(dir.path());
    // Two coils per step, but three during a make-before-break transition.
    let sc = scenario(dir.path(), "board = \"lcus\"\nmax_coils_on = 2");
    let (mut board, computer) = pty();
    let (r, _) = run(&options(&plan, &sc), link(&computer));
    assert!(matches!(
        r.as_ref().map_err(relay),
        Err(RelayError::TooManyOn {
            step: 1,
            count: 3,
            ..
        })
    ));
    assert!(leftover(&mut board).is_empty(), "bytes were sent");
    // Break-before-make keeps it at two.
    let sc = scenario(
        dir.path(),
        "board = \"lcus\"\nmax_coils_on = 2\norder = \"break-before-make\"",
    );
    replay::prepare(&options(&plan, &sc)).unwrap();
}

#[test]
fn on_time_refused_before_any_byte() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    // Coil 0 stays on through all three steps: 3 x (max(0.1 s x 1.5, 2 s floor) + 20 ms of
    // frames) = 6.06 s > 5 s less the guard's 100 ms.
    let plan = plan(dir.path(), "p.csv", &["0:1;1:2", "0:1;2:3", "0:1;3:4"], 0.1);
    let sc = scenario(
        dir.path(),
        "board = \"modbus\"\nmax_on_time_s = 5\ndwell_floor_ms = 2000",
    );
    let mut opts = options(&plan, &sc);
    opts.dwell_ms = None;
    let (mut board, computer) = pty();
    let (r, _) = run(&opts, link(&computer));
    let e = r.unwrap_err();
    assert!(matches!(relay(&e), RelayError::OnTooLong { .. }), "{e}");
    let msg = flagged(&e);
    assert!(
        msg.contains("coil 0 (channel 1) would stay on from step 0 through step 2 for 6.060 s, over 4.900 s (relay.max_on_time_s 5.000 s less the guard's 100 ms; each step counts its dwell and 20 ms of frames)"),
        "{msg}"
    );
    // and says what to do about it
    assert!(
        msg.contains("give a shorter --dwell-ms, or raise relay.max_on_time_s"),
        "{msg}"
    );
    assert!(leftover(&mut board).is_empty(), "bytes were sent");
    // Step mode cannot know the waits in advance: it is guarded while waiting instead.
    opts.mode = Mode::Step;
    replay::prepare(&opts).unwrap();
}

#[test]
fn unmapped_or_missing_channel_refused_before_any_byte() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let plan = plan(dir.path(), "p.csv", &["0:1;9:2"], 0.1);
    // Coil 9 is channel 10 by default, past an LCUS board's 8.
    let sc = scenario(dir.path(), "board = \"lcus\"");
    let (mut board, computer) = pty();
    let (r, _) = run(&options(&plan, &sc), link(&computer));
    let msg = flagged(&r.unwrap_err());
    assert!(
        msg.contains("coil 9, which is mapped to channel 10, but the lcus board has 8 channels")
            && msg.contains("at most 8"),
        "{msg}"
    );
    // A map that does not drive coil 9.
    let map = dir.path().join("map.toml");
    std::fs::write(&map, "board = \"numato\"\n[map]\n0 = 1\n1 = 2\n").unwrap();
    let mut opts = options(&plan, &sc);
    opts.map = Some(map);
    let (r, _) = run(&opts, link(&computer));
    let msg = flagged(&r.unwrap_err());
    assert!(
        msg.contains("coil 9, which no relay channel drives"),
        "{msg}"
    );
    assert!(leftover(&mut board).is_empty(), "bytes were sent");
}

const ALL_OFF_16: [u8; 11] = [
    0x01, 0x0F, 0x00, 0x00, 0x00, 0x10, 0x02, 0x00, 0x00, 0xE2, 0x20,
];

#[test]
fn board_closing_mid_replay_is_a_clear_error_and_the_log_resumes() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let plan = short_plan(dir.path());
    let sc = scenario(dir.path(), "board = \"modbus\"");
    let log = dir.path().join("replay.csv");
    let mut opts = options(&plan, &sc);
    opts.log = Some(log.clone());

    // The slave answers the all-off and step 0, then goes away on step 1's first frame.
    let (board, computer) = pty();
    let slave = modbus_slave(board, 4, |k| if k == 3 { Act::Close } else { Act::Answer });
    let (r, _) = run(&opts, link(&computer));
    let (got, _) = slave.join().unwrap();
    assert_eq!(got[3], [0x01, 0x05, 0x00, 0x02, 0xFF, 0x00, 0x2D, 0xFA]);
    let e = r.unwrap_err();
    // Closed while waiting for the reply, or while draining the frame (a race we do not
    // control); either way the all-off after it finds the port closed and says so.
    assert!(
        matches!(
            relay(&e).root(),
            RelayError::Closed { .. } | RelayError::Port { .. }
        ),
        "{e}"
    );
    let msg = flagged(&e);
    assert!(
        msg.contains(
            "switching all coils off FAILED: serial port pty: the board end closed the connection"
        ),
        "{msg}"
    );
    assert_eq!(replay::resume_step(&log).unwrap(), 1);
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(
        text.contains(",1,on,2,3,01 05 00 02 FF 00 2D FA\n"),
        "{text}"
    );
    drop(computer);

    // Resume at step 1 on a fresh board: step 0's coils are re-energised first.
    opts.from_step = replay::resume_step(&log).unwrap();
    let expected: Vec<Vec<u8>> = vec![
        ALL_OFF_16.to_vec(),
        vec![0x01, 0x05, 0x00, 0x00, 0xFF, 0x00, 0x8C, 0x3A], // hold step 0: channel 1
        vec![0x01, 0x05, 0x00, 0x01, 0xFF, 0x00, 0xDD, 0xFA], // hold step 0: channel 2
        vec![0x01, 0x05, 0x00, 0x02, 0xFF, 0x00, 0x2D, 0xFA], // step 1: channel 3 on
        vec![0x01, 0x05, 0x00, 0x01, 0x00, 0x00, 0x9C, 0x0A], // step 1: channel 2 off
        vec![0x01, 0x05, 0x00, 0x03, 0xFF, 0x00, 0x7C, 0x3A], // step 2: channel 4 on
        vec![0x01, 0x05, 0x00, 0x00, 0x00, 0x00, 0xCD, 0xCA], // step 2: channel 1 off
        ALL_OFF_16.to_vec(),
    ];
    let (board, computer) = pty();
    let slave = modbus_slave(board, expected.len(), |_| Act::Answer);
    let (r, _) = run(&opts, link(&computer));
    let (got, _board) = slave.join().unwrap();
    let summary = r.unwrap();
    assert_eq!(got, expected);
    assert_eq!(summary.steps_done, 2);
    assert_eq!(replay::resume_step(&log).unwrap(), 3);
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(
        text.starts_with("t_s,step,action,coil,channel,bytes\n"),
        "{text}"
    );
    assert_eq!(text.matches(",start,").count(), 2, "{text}");
    assert!(
        text.contains(",0,hold,0,1,01 05 00 00 FF 00 8C 3A\n"),
        "{text}"
    );
}

#[test]
fn step_mode_waits_for_enter_and_quits_on_q() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let sc = scenario(dir.path(), "board = \"lcus\"\nchannels = 4");
    let mut opts = options(&short_plan(dir.path()), &sc);
    opts.mode = Mode::Step;
    let (tx, rx) = std::sync::mpsc::channel();
    // Enter for step 0, then q before step 1 (queued up front: no timing involved).
    tx.send(String::new()).unwrap();
    tx.send("q".to_string()).unwrap();
    let (board, computer) = pty();
    let expected = [
        0xA0, 0x01, 0x00, 0xA1, 0xA0, 0x02, 0x00, 0xA2, 0xA0, 0x03, 0x00, 0xA3, 0xA0, 0x04, 0x00,
        0xA4, // all off
        0xA0, 0x01, 0x01, 0xA2, 0xA0, 0x02, 0x01, 0xA3, // step 0
        0xA0, 0x01, 0x00, 0xA1, 0xA0, 0x02, 0x00, 0xA2, 0xA0, 0x03, 0x00, 0xA3, 0xA0, 0x04, 0x00,
        0xA4, // all off after q
    ];
    let listener = listen(board, expected.len());
    let prep = replay::prepare(&opts).unwrap();
    let mut out = Vec::new();
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let summary = execute(&prep, link(&computer), stop, Some(rx), &mut out).unwrap();
    let (got, mut board) = listener.join().unwrap();
    assert_eq!(got, expected);
    assert!(leftover(&mut board).is_empty());
    assert!(summary.quit);
    assert_eq!(summary.next_step, 1);
    let text = String::from_utf8(out).unwrap();
    assert!(text.contains("resume with --from-step 1"), "{text}");
}

#[test]
fn one_board_closing_mid_replay_names_its_port_and_the_other_board_goes_off() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    // Two LCUS boards, no map: coils 0 and 1 on board 0 channels 1 and 2, coil 8 on board 1
    // channel 1.
    let sc = scenario(
        dir.path(),
        "[[relay.boards]]\nboard = \"lcus\"\n[[relay.boards]]\nboard = \"lcus\"",
    );
    let plan = plan(dir.path(), "p.csv", &["0:1;8:2", "1:3;8:2", "8:2"], 0.1);
    let mut opts = options(&plan, &sc);
    // Step mode: each step waits for a line, so the board end closes between two steps.
    opts.mode = Mode::Step;
    let (tx, rx) = std::sync::mpsc::channel();
    tx.send(String::new()).unwrap(); // Enter: step 0
    let (mut board0, computer0) = pty();
    let (mut board1, computer1) = pty();
    let (p0, p1) = (path_of(&computer0), path_of(&computer1));
    let links = vec![named_link(&computer0), named_link(&computer1)];
    let replay = std::thread::spawn(move || run_on(&opts, links, Some(rx)));
    let mut start = all_off_lcus8();
    start.extend([0xA0, 0x01, 0x01, 0xA2]); // step 0: channel 1 on
    assert_eq!(read_n(&mut board0, start.len()), start);
    assert_eq!(read_n(&mut board1, start.len()), start);
    // Board 0 goes away; step 1 begins by switching coil 1 on there. Board 0 comes first,
    // so board 1's all-off is sent after board 0's failed.
    drop(board0);
    await_hangup(&computer0);
    tx.send(String::new()).unwrap();
    let (r, text) = replay.join().unwrap();
    // Board 1 still gets its all-off, and nothing else.
    assert_eq!(read_n(&mut board1, 32), all_off_lcus8());
    assert!(leftover(&mut board1).is_empty());
    assert!(
        text.contains("    1 on           1     0       2  A0 02 01 A3"),
        "{text}"
    );
    let e = r.unwrap_err();
    assert!(
        matches!(
            relay(&e).root(),
            RelayError::Closed { .. } | RelayError::Port { .. }
        ),
        "{e}"
    );
    let msg = flagged(&e);
    assert!(
        msg.starts_with(&format!("board 0 ({p0}): serial port {p0}: ")),
        "{msg}"
    );
    assert!(
        msg.contains(&format!(
            "then switching all coils off FAILED on board 0 ({p0}): serial port {p0}: the board end closed the connection"
        )),
        "{msg}"
    );
    assert!(
        msg.contains(&format!(
            "the coils on board 0 may still be on: cut the coil supply (switched off: board 1 ({p1}))"
        )),
        "{msg}"
    );
    drop((computer0, computer1));
}

fn all_off_lcus8() -> Vec<u8> {
    (1..=8u8).flat_map(|c| [0xA0, c, 0x00, 0xA0 + c]).collect()
}

/// The replay binary with `args`: exit code and standard error.
fn replay_cli(args: &[&str]) -> (Option<i32>, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_spherestep"))
        .arg("replay")
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

#[test]
fn a_log_that_is_not_a_replay_log_is_refused_before_any_port_is_opened() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let plan = short_plan(dir.path());
    let sc = scenario(dir.path(), "board = \"lcus\"\nchannels = 4");
    // a first line that is a replay log's header and more, and one with trailing spaces
    let wider = dir.path().join("wider.csv");
    std::fs::write(&wider, "t_s,step,action,coil,channel,bytes,extra\n1,2\n").unwrap();
    let spaced = dir.path().join("spaced.csv");
    std::fs::write(&spaced, "t_s,step,action,coil,channel,bytes  \n").unwrap();
    let (mut board, computer) = pty();
    let port = path_of(&computer);
    let (p, s) = (plan.to_str().unwrap(), sc.to_str().unwrap());
    for target in [&plan, &sc, &wider, &spaced] {
        let before = std::fs::read(target).unwrap();
        let t = target.to_str().unwrap();
        let (code, err) = replay_cli(&[p, s, "--port", &port, "--dwell-ms", "0", "--log", t]);
        assert_eq!(code, Some(1), "{err}");
        assert!(err.contains(&format!("log {t}: ")), "names the file: {err}");
        assert!(
            err.contains("expected an empty or new file, or a replay log whose first line is exactly `t_s,step,action,coil,channel,bytes`"),
            "{err}"
        );
        assert_eq!(std::fs::read(target).unwrap(), before, "{t} changed");
        assert!(leftover(&mut board).is_empty(), "bytes were sent");
    }
    // the plan is not appended to by a dry run either
    let before = std::fs::read(&plan).unwrap();
    let (code, err) = replay_cli(&[p, s, "--dry-run", "--log", p]);
    assert_eq!(code, Some(1), "{err}");
    assert_eq!(std::fs::read(&plan).unwrap(), before);
    // in-process: `prepare` refuses it, naming the file and what its first line is
    let mut opts = options(&plan, &sc);
    opts.log = Some(plan.clone());
    let e = replay::prepare(&opts).unwrap_err();
    assert!(matches!(relay(&e), RelayError::Log { .. }), "{e}");
    assert!(
        e.to_string()
            .contains("its first line is `step,pivot_coil,"),
        "{e}"
    );
    // A new file, an empty one and a replay log are written or appended to, on a line of its own.
    let log = dir.path().join("replay.csv");
    let header = "t_s,step,action,coil,channel,bytes";
    for (start, runs) in [(None, 1), (Some(""), 1), (Some(header), 2)] {
        let _ = std::fs::remove_file(&log);
        if let Some(t) = start {
            std::fs::write(&log, t).unwrap();
        }
        opts.log = Some(log.clone());
        let (r, _) = run(&opts, spherestep::relay::Link::dry_run());
        r.unwrap();
        if start == Some(header) {
            let (r, _) = run(&opts, spherestep::relay::Link::dry_run());
            r.unwrap();
        }
        let text = std::fs::read_to_string(&log).unwrap();
        assert!(
            text.starts_with(&format!("{header}\n0.000,0,start,")),
            "{text}"
        );
        assert_eq!(text.matches(header).count(), 1, "{text}");
        assert_eq!(text.matches(",start,").count(), runs, "{text}");
        assert!(text.lines().all(|l| l.split(',').count() == 6), "{text}");
    }
    drop(computer);
}
