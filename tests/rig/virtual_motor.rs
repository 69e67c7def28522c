//! The hardware path rehearsed end to end: `spherestep virtual` plays the relay boards (and a
//! sensor) on pseudo-terminals, `spherestep replay` drives them. For each board protocol the
//! main-job plan ends where `simulate` says, with no violation; each injected fault stops the
//! replay with every coil off, a message saying what happened and where to resume. Every wait
//! has a deadline (the harness kills what it started), and nothing asserts how fast anything
//! ran: the virtual clock runs 5 times the wall clock and the replay's dwells are 5 times
//! shorter, so the ball has the plan's dwells on the virtual clock whatever the machine.
#![cfg(unix)]

use crate::common;

use spherestep::commands::{plan_settings, PlanOverrides};
use spherestep::io::planfile::write_plan;
use spherestep::io::scenario::Scenario;
use spherestep::model::geometry::orientation_from_xyzw;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

/// Longest anything may take before the harness gives up (a guard against hangs).
const GUARD: Duration = Duration::from_secs(120);

/// The virtual clock's speed, and the replay's dwell factor and on-time limit scaled by it
/// (the plan keeps to 10 s at a factor of 1.5).
const SPEED: &str = "5";
const FAST_RELAY: &str = "dwell_factor = 0.3\ndwell_floor_ms = 40\nmax_on_time_s = 2.0\n";

/// The plant's relay section for a protocol (two 8-channel boards for LCUS and KMTronic),
/// and the replay's (the same boards, dwells and on-time scaled to the virtual clock). The
/// plant allows 11 s on the virtual clock: the plan's 10 s and what the replay's own
/// switching and the machine's scheduling add (times the speed).
fn relay_sections(board: &str) -> (String, String) {
    let boards = match board {
        "lcus" | "kmtronic" => {
            format!(
                "[[relay.boards]]\nboard = \"{board}\"\n[[relay.boards]]\nboard = \"{board}\"\n"
            )
        }
        _ => String::new(),
    };
    let single = if boards.is_empty() {
        format!("board = \"{board}\"\n")
    } else {
        String::new()
    };
    (
        format!("[relay]\n{single}max_on_time_s = 11.0\n{boards}"),
        format!("[relay]\n{single}{FAST_RELAY}{boards}"),
    )
}

/// The main job (90 degrees about Y on the prototype), written as `plan` writes it.
fn main_job(dir: &Path) -> (PathBuf, Scenario) {
    let sc = Scenario::load(Path::new("scenarios/prototype.toml")).unwrap();
    let o = PlanOverrides {
        axis: Some("0,1,0".into()),
        angle_deg: Some(90.0),
        ..Default::default()
    };
    let p = sc.motor().plan(&plan_settings(&sc, &o).unwrap());
    assert!(p.reached, "{:?}", p.message);
    let mut csv = Vec::new();
    write_plan(&p.rows, &mut csv).unwrap();
    let path = dir.join("plan.csv");
    std::fs::write(&path, csv).unwrap();
    (path, sc)
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// A child process with its output gathered on threads.
struct Running {
    child: Child,
    out: mpsc::Receiver<String>,
    err: mpsc::Receiver<String>,
}

fn spawn(args: &[&str]) -> Running {
    let mut child = Command::new(common::bin())
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (to, out) = mpsc::channel();
    let stdout = child.stdout.take().unwrap();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if to.send(line).is_err() {
                break;
            }
        }
    });
    let (te, err) = mpsc::channel();
    let mut stderr = child.stderr.take().unwrap();
    std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stderr.read_to_string(&mut s);
        let _ = te.send(s);
    });
    Running { child, out, err }
}

impl Running {
    /// Waits for a stdout line starting with `prefix`; the lines up to it.
    fn until(&mut self, prefix: &str) -> Vec<String> {
        self.until_line(&format!("'{prefix}...'"), |l| l.starts_with(prefix))
    }

    /// Waits for a stdout line containing `needle`; the lines up to it.
    fn until_containing(&mut self, needle: &str) -> Vec<String> {
        self.until_line(&format!("with '{needle}'"), |l| l.contains(needle))
    }

    /// Waits for a stdout line that is `done` (killing the child past the guard, the panic
    /// saying which line, `what`, did not come); the lines up to it.
    fn until_line(&mut self, what: &str, done: impl Fn(&str) -> bool) -> Vec<String> {
        let mut seen = Vec::new();
        loop {
            match self.out.recv_timeout(GUARD) {
                Ok(l) => {
                    let found = done(&l);
                    seen.push(l);
                    if found {
                        return seen;
                    }
                }
                Err(_) => {
                    let _ = self.child.kill();
                    panic!("no line {what} in time; got {seen:?}");
                }
            }
        }
    }

    /// Waits for the end (killing it past the guard): exit code, stdout, stderr.
    fn finish(mut self) -> (i32, String, String) {
        let deadline = std::time::Instant::now() + GUARD;
        let code = loop {
            if let Some(s) = self.child.try_wait().unwrap() {
                break s.code().unwrap_or(-1);
            }
            if std::time::Instant::now() > deadline {
                let _ = self.child.kill();
                let _ = self.child.wait();
                panic!("did not end in time");
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        // every line up to the end of its output: the reader thread may still be passing on
        // the last ones (the summary) when the process has ended
        let mut out = Vec::new();
        let end = std::time::Instant::now() + GUARD;
        while let Ok(l) = self
            .out
            .recv_timeout(end.saturating_duration_since(std::time::Instant::now()))
        {
            out.push(l);
        }
        let err = self.err.recv_timeout(GUARD).unwrap_or_default();
        (code, out.join("\n"), err)
    }
}

/// What one rehearsal gave: the replay's exit code, stdout and stderr, the virtual motor's
/// summary (JSON), exit code and log.
struct Rehearsal {
    replay: (i32, String, String),
    summary: serde_json::Value,
    virtual_code: i32,
    log: String,
}

/// Runs the virtual motor on `plant` with `extra` arguments, then the replay of `plan` with
/// `scenario` and `replay_extra` on its ports.
fn rehearse(
    dir: &Path,
    plant: &Path,
    plan: &Path,
    scenario: &Path,
    extra: &[&str],
    replay_extra: &[&str],
) -> Rehearsal {
    let files = Files {
        plant,
        plan,
        scenario,
    };
    rehearse_at(dir, files, SPEED, extra, replay_extra, |_| {})
}

/// The files of a rehearsal.
#[derive(Clone, Copy)]
struct Files<'a> {
    plant: &'a Path,
    plan: &'a Path,
    scenario: &'a Path,
}

/// [`rehearse`] with the virtual clock at `speed`; `during` is given the running replay
/// before it is waited for (to signal it).
fn rehearse_at(
    dir: &Path,
    files: Files,
    speed: &str,
    extra: &[&str],
    replay_extra: &[&str],
    during: impl FnOnce(&mut Running),
) -> Rehearsal {
    let Files {
        plant,
        plan,
        scenario,
    } = files;
    let links = dir.join("dev");
    let log = dir.join("virtual.csv");
    let (links_s, log_s) = (links.display().to_string(), log.display().to_string());
    let mut args = vec![
        "virtual",
        plant.to_str().unwrap(),
        "--speed",
        speed,
        "--link-dir",
        &links_s,
        "--log",
        &log_s,
        "--json",
        "--max-seconds",
        "100",
    ];
    args.extend_from_slice(extra);
    let mut v = spawn(&args);
    let ports = v.until("ready:");
    // the replay it suggests names the plan it rehearses, when one was given
    let given = extra
        .iter()
        .position(|a| *a == "--plan")
        .map(|i| extra[i + 1]);
    let ready = ports.last().map_or("", String::as_str);
    let suggested = format!("spherestep replay {} ", given.unwrap_or("PLAN.csv"));
    assert!(ready.contains(&suggested), "{ready}");
    let boards = ports.iter().filter(|l| l.starts_with("board ")).count();
    let mut r: Vec<String> = vec![
        "replay".into(),
        plan.display().to_string(),
        scenario.display().to_string(),
    ];
    for k in 0..boards {
        r.push("--port".into());
        r.push(links.join(format!("board{k}")).display().to_string());
    }
    r.extend(replay_extra.iter().map(|s| s.to_string()));
    let r: Vec<&str> = r.iter().map(String::as_str).collect();
    let mut running = spawn(&r);
    during(&mut running);
    let replay = running.finish();
    let (virtual_code, out, err) = v.finish();
    let json = out.find('{').map(|i| &out[i..]).unwrap_or("");
    let summary: serde_json::Value = serde_json::from_str(json)
        .unwrap_or_else(|e| panic!("no summary ({e}): {out}\n{err}\nreplay: {replay:?}"));
    Rehearsal {
        replay,
        summary,
        virtual_code,
        log: std::fs::read_to_string(&log).unwrap_or_default(),
    }
}

/// The coils on in the log's last row (the `end` row).
fn coils_on_at_end(log: &str) -> String {
    let last = log.lines().last().unwrap_or_default();
    // t_s,port,"frame","what",coils_on,qx,qy,qz,qw: the fifth field from the end
    let fields: Vec<&str> = last.rsplitn(6, ',').collect();
    assert!(last.contains("\"end\""), "{last}");
    fields[4].to_string()
}

fn main_job_on(board: &str) {
    let dir = tempfile::tempdir().unwrap();
    let (plan, sc) = main_job(dir.path());
    let (plant_relay, replay_relay) = relay_sections(board);
    let plant = write(
        dir.path(),
        "plant.toml",
        &format!("name = \"plant\"\n{plant_relay}"),
    );
    let scenario = write(
        dir.path(),
        "fast.toml",
        &format!("name = \"fast\"\n{replay_relay}"),
    );
    let plan_s = plan.display().to_string();
    let verify: &[&str] = if board == "lcus" { &[] } else { &["--verify"] };
    let r = rehearse(
        dir.path(),
        &plant,
        &plan,
        &scenario,
        &["--plan", &plan_s],
        verify,
    );
    assert_eq!(r.replay.0, 0, "{board}: {:?}", r.replay);
    assert!(r.replay.1.contains("all coils off"), "{}", r.replay.1);
    let s = &r.summary;
    assert_eq!(s["violations_total"], 0, "{board}: {s:#}");
    assert_eq!(s["unknown_frames"], 0, "{board}: {s:#}");
    // the port links are gone with the virtual motor
    let left: Vec<_> = std::fs::read_dir(dir.path().join("dev")).unwrap().collect();
    assert!(left.is_empty(), "{board}: links left behind: {left:?}");
    assert_eq!(r.virtual_code, 0, "{board}: {s:#}");
    assert!(s["relays_on_at_end"].as_array().unwrap().is_empty());
    assert_eq!(coils_on_at_end(&r.log), "");
    // where simulate says the ball ends
    let rows = spherestep::io::planfile::read_plan(&plan).unwrap();
    let sim = sc.motor().simulate(&rows);
    let want = sim.last().unwrap().q;
    let q: Vec<f64> = (0..4)
        .map(|k| s["final_orientation"][k].as_f64().unwrap())
        .collect();
    let got = orientation_from_xyzw(q[0], q[1], q[2], q[3]).unwrap();
    let off = got.angle_to(&want).to_degrees();
    assert!(
        off < 1.0,
        "{board}: the ball ends {off} degrees from simulate's"
    );
}

#[test]
fn numato_replay_ends_where_simulate_says() {
    let _one = crate::one_at_a_time();
    main_job_on("numato");
}

#[test]
fn modbus_replay_ends_where_simulate_says() {
    let _one = crate::one_at_a_time();
    main_job_on("modbus");
}

#[test]
fn lcus_replay_on_two_boards_ends_where_simulate_says() {
    let _one = crate::one_at_a_time();
    main_job_on("lcus");
}

#[test]
fn kmtronic_replay_on_two_boards_ends_where_simulate_says() {
    let _one = crate::one_at_a_time();
    main_job_on("kmtronic");
}

/// A fault's rehearsal on a numato board (read back with --verify), and what the replay said.
fn fault(extra: &[&str], sensor: Option<&str>) -> (Rehearsal, String) {
    let dir = tempfile::tempdir().unwrap();
    let (plan, _) = main_job(dir.path());
    let plant = write(
        dir.path(),
        "plant.toml",
        "name = \"plant\"\n[relay]\nboard = \"numato\"\nmax_on_time_s = 11.0\n",
    );
    // the closed loop keeps the coils on while it reads and decides: room on the wall clock
    let scenario = write(
        dir.path(),
        "fast.toml",
        "name = \"fast\"\n[relay]\nboard = \"numato\"\ndwell_factor = 0.3\ndwell_floor_ms = 40\nmax_on_time_s = 5.0\n",
    );
    let plan_s = plan.display().to_string();
    let mut v_args = vec!["--plan", plan_s.as_str()];
    v_args.extend_from_slice(extra);
    let sensor_path = dir.path().join("dev").join("sensor").display().to_string();
    let mut r_args = vec!["--verify"];
    if let Some(f) = sensor {
        v_args.extend_from_slice(&["--sensor", f]);
        r_args.extend_from_slice(&["--sensor", &sensor_path, "--sensor-format", f]);
    }
    let r = rehearse(dir.path(), &plant, &plan, &scenario, &v_args, &r_args);
    let said = format!("{}\n{}", r.replay.1, r.replay.2);
    assert_ne!(r.replay.0, 0, "the replay went on: {said}");
    assert_eq!(coils_on_at_end(&r.log), "", "{}", r.log);
    assert!(r.summary["relays_on_at_end"].as_array().unwrap().is_empty());
    (r, said)
}

#[test]
fn a_port_that_vanishes_stops_the_replay_with_the_step_to_resume_from() {
    let _one = crate::one_at_a_time();
    // the board is unplugged: its relays lose power (the virtual motor's log shows them
    // released), the replay's all-off cannot reach it and says so, and where to resume
    let (r, said) = fault(&["--drop-after-frames", "9"], None);
    assert!(said.contains("closed the connection"), "{said}");
    assert!(said.contains("switching all coils off FAILED"), "{said}");
    assert!(
        said.contains("once every board answers again, resume with --from-step 2"),
        "{said}"
    );
    assert!(r.log.contains("\"dropped\""), "{}", r.log);
}

#[test]
fn a_stuck_relay_is_found_by_the_read_back() {
    let _one = crate::one_at_a_time();
    // coil 12 (channel 13) goes on in step 0 of the plan about Y
    let (_, said) = fault(&["--stuck-relay", "13"], None);
    assert!(
        said.contains("all coils switched off; resume with --from-step 0"),
        "{said}"
    );
    assert!(
        said.to_lowercase().contains("read back")
            || said.contains("mismatch")
            || said.contains("verify"),
        "{said}"
    );
}

#[test]
fn a_sensor_that_stalls_stops_the_closed_loop() {
    let _one = crate::one_at_a_time();
    // the closed loop's message (written against its current behaviour) names the sensor and
    // the steps done; --from-step is refused with --sensor, so it names none
    let (r, said) = fault(&["--sensor-stall-after", "40"], Some("quat-csv"));
    assert!(
        said.contains("(quat-csv): no reading within 500 ms"),
        "{said}"
    );
    assert!(
        said.contains("all coils switched off (closed loop:"),
        "{said}"
    );
    assert!(r.summary["sensor_readings"].as_u64().unwrap() >= 40);
    // the sensor's port says the order of its quaternion: w first, as the device sends it
    let ports = r.summary["ports"].as_array().unwrap();
    let sensor = ports
        .iter()
        .find_map(|p| p["what"].as_str().filter(|w| w.starts_with("sensor")));
    assert_eq!(
        sensor,
        Some("sensor (quat-csv: lines w,x,y,z, as the device sends them)")
    );
}

#[test]
fn a_garbling_sensor_stops_the_closed_loop() {
    let _one = crate::one_at_a_time();
    // every reading garbled: the first is the tare's, taken before any coil is switched
    let (r, said) = fault(&["--sensor-garble", "1"], Some("bno055"));
    assert!(said.contains("(bno055): unexpected reply 5A"), "{said}");
    assert!(
        said.contains("it was the tare reading") && said.contains("no coil was switched"),
        "{said}"
    );
    assert!(r.summary["garbled_readings"].as_u64().unwrap() >= 1);
    let ports = r.summary["ports"].as_array().unwrap();
    let sensor = ports
        .iter()
        .find_map(|p| p["what"].as_str().filter(|w| w.starts_with("sensor")));
    assert_eq!(
        sensor,
        Some("sensor (bno055: quaternion registers w,x,y,z, as the device has them)")
    );
}

#[test]
fn bad_arguments_are_refused_before_any_port_is_made() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let plant = write(dir.path(), "plant.toml", "[relay]\nboard = \"numato\"\n");
    let p = plant.to_str().unwrap();
    for (args, needle) in [
        (
            vec!["--speed", "0"],
            "argument --speed: expected a number > 0",
        ),
        (vec!["--stuck-relay", "17"], "argument --stuck-relay"),
        (
            vec!["--sensor-garble", "0.5"],
            "argument --sensor-garble: expected a sensor",
        ),
        (
            vec!["--sensor", "bno055", "--sensor-garble", "2"],
            "a fraction from 0 to 1",
        ),
        (vec!["--mount", "0,0,0,0"], "argument --mount"),
        (
            vec!["--mount", "0,0,0,3"],
            "argument --mount: expected a unit quaternion",
        ),
        (
            vec!["--drop-after-frames", "0"],
            "argument --drop-after-frames",
        ),
    ] {
        let (code, out, err) = common::run(&[&["virtual", p][..], &args].concat());
        assert_eq!(code, 1, "{args:?}: {out}{err}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!out.contains("ready:"), "{args:?}: {out}");
    }
    // the log is never written over a file the virtual motor reads
    let before = std::fs::read(&plant).unwrap();
    let (code, out, err) = common::run(&["virtual", p, "--log", p]);
    assert_eq!(code, 1, "{out}{err}");
    assert!(
        err.contains("argument --log: expected a file that is not one of the command's inputs"),
        "{err}"
    );
    assert_eq!(std::fs::read(&plant).unwrap(), before);
    let plan = write(dir.path(), "p.csv", "step,active\n");
    let (code, _, err) = common::run(&[
        "virtual",
        p,
        "--plan",
        plan.to_str().unwrap(),
        "--log",
        plan.to_str().unwrap(),
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("argument --log"), "{err}");
    assert_eq!(std::fs::read_to_string(&plan).unwrap(), "step,active\n");
    // a link that points at a port that exists is another virtual motor's: left alone
    let links = dir.path().join("dev");
    std::fs::create_dir_all(&links).unwrap();
    std::os::unix::fs::symlink("/dev/null", links.join("board0")).unwrap();
    let l = links.to_str().unwrap();
    let (code, out, err) = common::run(&["virtual", p, "--link-dir", l, "--max-seconds", "5"]);
    assert_eq!(code, 1, "{out}{err}");
    assert!(
        err.contains("links to /dev/null, a port that exists") && !out.contains("ready:"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_link(links.join("board0")).unwrap(),
        Path::new("/dev/null")
    );
    let none = dir.path().join("none.toml");
    let (code, _, err) = common::run(&["virtual", none.to_str().unwrap()]);
    assert_eq!(code, 1);
    assert!(err.contains("none.toml"), "{err}");
    let bare = write(dir.path(), "bare.toml", "");
    let (code, _, err) = common::run(&["virtual", bare.to_str().unwrap()]);
    assert_eq!(code, 1);
    assert!(
        err.contains("argument --board") && err.contains("bare.toml"),
        "{err}"
    );
}

#[test]
fn a_coil_on_too_long_and_too_many_coils_on_are_reported() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let mut plan = String::from(
        "step,pivot_coil,pivot_magnet,new_coil,new_magnet,active,qx,qy,qz,qw,step_angle_deg,step_axis_error_deg,cum_angle_deg,cum_axis_error_deg,settle_time_s\n",
    );
    for (k, active) in ["0:10;1:11", "0:10;2:12", "2:12;3:13"].iter().enumerate() {
        plan.push_str(&format!("{k},,,,,{active},0,0,0,1,0,0,0,0,0.1\n"));
    }
    let plan = write(dir.path(), "plan.csv", &plan);
    // the plant's coils take 1 s (virtual: 0.2 s of the replay's) and two at once
    let plant = write(
        dir.path(),
        "plant.toml",
        "[relay]\nboard = \"numato\"\nmax_on_time_s = 1.0\nmax_coils_on = 2\n",
    );
    let scenario = write(dir.path(), "replay.toml", "[relay]\nboard = \"numato\"\n");
    let r = rehearse(
        dir.path(),
        &plant,
        &plan,
        &scenario,
        &[],
        &["--dwell-ms", "300"],
    );
    assert_eq!(r.replay.0, 0, "{:?}", r.replay);
    assert_eq!(r.virtual_code, 1);
    let v: Vec<String> = (r.summary["violations"].as_array().unwrap().iter())
        .map(|x| x.as_str().unwrap().to_string())
        .collect();
    assert!(
        v.iter()
            .any(|x| x.contains("coil 0 (board 0, channel 1) on for")
                && x.contains("past max_on_time_s")),
        "{v:?}"
    );
    assert!(
        v.iter()
            .any(|x| x.contains("3 relays on at once") && x.contains("more than max_coils_on (2)")),
        "{v:?}"
    );
    assert!(r.log.contains("\"violation\""), "{}", r.log);
    assert_eq!(coils_on_at_end(&r.log), "");
}

/// The longest any coil was on, seconds, from the virtual motor's own log (its clock; a coil
/// still on at the last row counts until it), and which.
fn longest_on_in_log(log: &str) -> (f64, String) {
    let mut since: std::collections::BTreeMap<String, f64> = Default::default();
    let mut longest = (0.0, String::new());
    for line in log.lines().skip(1) {
        // t_s,port,"frame","what",coils_on,qx,qy,qz,qw
        let t: f64 = line.split(',').next().unwrap().parse().unwrap();
        let fields: Vec<&str> = line.rsplitn(6, ',').collect();
        let on: Vec<String> = (fields[4].split(';'))
            .filter(|c| !c.is_empty())
            .map(String::from)
            .collect();
        since.retain(|c, from| {
            let kept = on.contains(c);
            if !kept && t - *from > longest.0 {
                longest = (t - *from, c.clone());
            }
            kept
        });
        for c in on {
            since.entry(c).or_insert(t);
        }
        for (c, from) in &since {
            if t - from > longest.0 {
                longest = (t - from, c.clone());
            }
        }
    }
    longest
}

/// Two 8-channel numato boards (coils 0-7 on board 0, 8-15 on board 1), each with a reply
/// timeout of `timeout_ms`, and coils allowed `max_on_time_s`.
fn two_numato(max_on_time_s: f64, timeout_ms: u64) -> String {
    let board =
        format!("[[relay.boards]]\nboard = \"numato\"\nchannels = 8\ntimeout_ms = {timeout_ms}\n");
    format!("[relay]\nmax_on_time_s = {max_on_time_s}\n{board}{board}")
}

/// A plan whose rows have these active sets (`coil:magnet;...`), settle times 0.1 s.
fn plan_of(dir: &Path, rows: &[&str]) -> PathBuf {
    let mut plan = String::from(
        "step,pivot_coil,pivot_magnet,new_coil,new_magnet,active,qx,qy,qz,qw,step_angle_deg,step_axis_error_deg,cum_angle_deg,cum_axis_error_deg,settle_time_s\n",
    );
    for (k, active) in rows.iter().enumerate() {
        plan.push_str(&format!("{k},,,,,{active},0,0,0,1,0,0,0,0,0.1\n"));
    }
    write(dir, "plan.csv", &plan)
}

/// Step 0 switches coil 0 on board 0, then coil 12 on board 1, which has stopped answering
/// (it answered the first all-off only): the replay waits for board 1 with coil 0 on.
fn silent_board_1(
    max_on_time_s: f64,
    timeout_ms: u64,
    during: impl FnOnce(&mut Running),
) -> Rehearsal {
    let dir = tempfile::tempdir().unwrap();
    let plan = plan_of(dir.path(), &["0:10;12:11", "1:12", "1:12"]);
    let relay = two_numato(max_on_time_s, timeout_ms);
    let plant = write(dir.path(), "plant.toml", &relay);
    let scenario = write(dir.path(), "replay.toml", &relay);
    let files = Files {
        plant: &plant,
        plan: &plan,
        scenario: &scenario,
    };
    let plan_s = plan.display().to_string();
    let extra = [
        "--plan",
        &plan_s,
        "--silent-after-frames",
        "1",
        "--fault-board",
        "1",
    ];
    let r = rehearse_at(
        dir.path(),
        files,
        "1",
        &extra,
        &["--dwell-ms", "200"],
        during,
    );
    assert_ne!(r.replay.0, 0, "{:?}", r.replay);
    assert!(r.log.contains("\"silent\""), "{}", r.log);
    assert_eq!(r.summary["violations_total"], 0, "{:#}", r.summary);
    assert_eq!(coils_on_at_end(&r.log), "", "{}", r.log);
    r
}

#[test]
fn a_silent_board_holds_no_coil_of_another_board_past_its_limit() {
    let _one = crate::one_at_a_time();
    // board 1 waits 5 s for an answer; coil 0 may stay on 1 s
    let r = silent_board_1(1.0, 5000, |_| {});
    let said = format!("{}\n{}", r.replay.1, r.replay.2);
    let (on, coil) = longest_on_in_log(&r.log);
    assert!(
        on < 1.0,
        "coil {coil} on for {on} s (the far end's clock)\n{said}"
    );
    assert!(
        on > 0.8,
        "coil {coil} only on for {on} s: went off early?\n{said}"
    );
    assert!(
        said.contains("coil 0 (board 0, channel 1) had been on")
            && said.contains("waiting for a reply from board 1 (")
            && said.contains("which had not answered after")
            && said.contains("this one after")
            && said.contains("within the limit"),
        "{said}"
    );
    // board 0 was switched off first, board 1 never answered its all-off either
    assert!(said.contains("switching all coils off FAILED"), "{said}");
    assert!(!said.contains("PAST the limit"), "{said}");
}

/// Signals `signal` to the replay once it waits for silent board 1 with coil 0 on, and
/// checks every coil went off at once (on the far end's clock).
fn signal_while_a_board_is_silent(signal: &str) {
    let pause = Duration::from_millis(300);
    let r = silent_board_1(10.0, 3000, |replay| {
        let seen = replay.until_containing("\"relay on 0\\r\"");
        assert!(!seen.is_empty());
        std::thread::sleep(pause);
        let pid = replay.child.id().to_string();
        let killed = Command::new("kill").args([signal, &pid]).status().unwrap();
        assert!(killed.success());
    });
    let said = format!("{}\n{}", r.replay.1, r.replay.2);
    assert!(said.contains("interrupted by a signal"), "{said}");
    // the wait for board 1 (3 s) was not waited out: coil 0 went off within a second of the
    // signal
    let (on, coil) = longest_on_in_log(&r.log);
    assert!(
        on < (pause + Duration::from_secs(1)).as_secs_f64(),
        "coil {coil} on for {on} s after {signal}\n{said}"
    );
}

#[test]
fn sigint_while_a_board_is_silent_switches_every_coil_off_at_once() {
    let _one = crate::one_at_a_time();
    signal_while_a_board_is_silent("-INT");
}

#[test]
fn sighup_while_a_board_is_silent_switches_every_coil_off_at_once() {
    let _one = crate::one_at_a_time();
    signal_while_a_board_is_silent("-HUP");
}

#[test]
fn the_on_time_check_keeps_a_margin_for_frames_and_the_guard() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    // coil 0 on for four steps: 4 x 300 ms is the limit itself, refused before any byte goes
    let plan = plan_of(dir.path(), &["0:10", "0:10", "0:10", "0:10", "1:11"]);
    let scenario = write(
        dir.path(),
        "replay.toml",
        "[relay]\nboard = \"numato\"\nmax_on_time_s = 1.2\n",
    );
    let (p, sc) = (plan.to_str().unwrap(), scenario.to_str().unwrap());
    let (code, out, err) = common::run(&["replay", p, sc, "--dry-run", "--dwell-ms", "300"]);
    assert_eq!(code, 1, "{out}{err}");
    assert!(
        err.contains("coil 0 (channel 1) would stay on from step 0 through step 3 for 1.280 s")
            && err.contains("1.100 s (relay.max_on_time_s 1.200 s less the guard's 100 ms"),
        "{err}"
    );
    assert!(!out.contains("relay on"), "{out}");
    // 4 x 250 ms fits: on the wire (the far end's clock) the coil stays within the limit
    let plant = write(
        dir.path(),
        "plant.toml",
        "[relay]\nboard = \"numato\"\nmax_on_time_s = 1.2\n",
    );
    let files = Files {
        plant: &plant,
        plan: &plan,
        scenario: &scenario,
    };
    let plan_s = plan.display().to_string();
    let r = rehearse_at(
        dir.path(),
        files,
        "1",
        &["--plan", &plan_s],
        &["--dwell-ms", "250", "--verify"],
        |_| {},
    );
    assert_eq!(r.replay.0, 0, "{:?}", r.replay);
    assert_eq!(r.summary["violations_total"], 0, "{:#}", r.summary);
    let (on, coil) = longest_on_in_log(&r.log);
    assert!(on > 1.0 && on < 1.2, "coil {coil} on for {on} s");
}

#[test]
fn a_silent_board_fault_names_a_board_of_the_plant() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let plant = write(dir.path(), "plant.toml", &two_numato(1.0, 1000));
    let p = plant.to_str().unwrap();
    let (code, _, err) = common::run(&[
        "virtual",
        p,
        "--silent-after-frames",
        "1",
        "--fault-board",
        "2",
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("argument --fault-board: expected a board of the plant, 0 to 1, got 2"),
        "{err}"
    );
}
