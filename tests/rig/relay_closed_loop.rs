//! The closed loop on the hardware (`replay --sensor`), on pseudo-terminals: two LCUS boards
//! and an orientation sensor played on the far ends by a plant that follows the relays (it
//! reports, for the coils on, the orientation a script gives). A plan of the broad-well motor
//! played as predicted (no replan), with a stray measurement (a replan, checked frame by frame
//! against the controller run offline on the same readings), on a BNO055, and a sensor that
//! closes or sends garbage mid-run: every coil off on both boards, the sensor named.

use crate::common::relay_support;
use crate::common::scripted::{
    board, line_of, offline, quat_csv_end, Ball, Next, Received, Script, Shared,
};

use relay_support::{lcus_all_off, path_of, pty, GUARD};
use serialport::{SerialPort, TTYPort};
use spherestep::commands::closed_replay::{execute, prepare_closed, ClosedInputs, SensorOptions};
use spherestep::commands::replay::{Flagged, ReplayOptions};
use spherestep::io::scenario::Scenario;
use spherestep::model::geometry::Radians;
use spherestep::planning::closed_loop::{run_closed_loop, LoopSettings};
use spherestep::relay::{Link, RelayError};
use spherestep::rig::ClosedSummary;
use spherestep::rig::RigError;
use spherestep::sensor::bno055::FusionMode;
use spherestep::sensor::{self, quat_csv::parse_line, SensorFormat};
use std::collections::BTreeSet;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

const MODEL: &str = "scenarios/broad-wells.toml";
/// Two 8-channel LCUS boards, the coils laid onto them in order (0..=7, then 8..=15).
const TWO_LCUS: &str =
    "max_coils_on = 8\n[[boards]]\nboard = \"lcus\"\n[[boards]]\nboard = \"lcus\"\n";
/// The dwell of every step: a wide margin for the far ends to have seen the switching before
/// the reading (under load too).
const DWELL_MS: u64 = 100;

/// A broad-well plan of 30 degrees about Y, written to `dir` and read back as the replay will.
fn plan_file(dir: &Path) -> PathBuf {
    relay_support::broad_plan(dir, MODEL)
}

fn options(dir: &Path, plan: &Path) -> ReplayOptions {
    let map = dir.join("boards.toml");
    std::fs::write(&map, TWO_LCUS).unwrap();
    let mut o = ReplayOptions::new(plan);
    o.scenario = Some(MODEL.into());
    o.map = Some(map);
    o.dwell_ms = Some(DWELL_MS);
    o.log = Some(dir.join("log.csv"));
    o
}

/// One LCUS frame.
fn lcus(ch: u8, on: bool) -> [u8; 4] {
    let op = u8::from(on);
    [0xA0, ch, op, 0xA0u8.wrapping_add(ch).wrapping_add(op)]
}

/// The bytes each board receives for `sets` switched in turn (make-before-break, coils laid
/// 8 per board), from all off to all off.
fn expected_frames(sets: &[BTreeSet<usize>]) -> [Vec<u8>; 2] {
    let mut out = [lcus_all_off(8), lcus_all_off(8)];
    let mut prev = BTreeSet::new();
    for set in sets {
        for (c, on) in set
            .difference(&prev)
            .map(|&c| (c, true))
            .chain(prev.difference(set).map(|&c| (c, false)))
        {
            out[c / 8].extend(lcus((c % 8) as u8 + 1, on));
        }
        prev = set.clone();
    }
    for o in &mut out {
        o.extend(lcus_all_off(8));
    }
    out
}

/// The longest time any relay of the boards was on, as their far ends saw it (a relay left
/// on at the end counts until `end`).
fn longest_on(received: &[Received], end: Instant) -> Duration {
    let mut longest = Duration::ZERO;
    for (bytes, times) in received {
        let mut since: [Option<Instant>; 9] = [None; 9];
        for (f, &t) in bytes.chunks_exact(4).zip(times) {
            let ch = usize::from(f[1]);
            match (f[2] == 1, since[ch]) {
                (true, None) => since[ch] = Some(t),
                (false, Some(s)) => {
                    longest = longest.max(t - s);
                    since[ch] = None;
                }
                _ => {}
            }
        }
        for s in since.into_iter().flatten() {
            longest = longest.max(end - s);
        }
    }
    longest
}

/// How the quat-csv far end misbehaves once the script reaches an entry.
#[derive(Clone, Copy, PartialEq)]
enum Fault {
    None,
    /// Closes its end.
    Close(usize),
    /// Prints this line instead of readings.
    Garbage(usize, &'static str),
    /// Prints this line from step 0 on (after the tare), whatever the plant does.
    Always(&'static str),
    /// Prints nothing from step 0 on (after the tare).
    Silent,
    /// (BNO055) reports this CALIB_STAT byte (else 0xFF, all calibrated).
    Calibration(u8),
}

/// A quat-csv far end: prints the plant's orientation every 10 ms until `done`.
fn printer(port: TTYPort, plant: Shared, fault: Fault, done: Arc<AtomicBool>) -> JoinHandle<()> {
    quat_csv_end(port, done, move || {
        let (at, q) = {
            let p = plant.lock().unwrap();
            (p.at, p.now())
        };
        match fault {
            Fault::Close(k) if at == Some(k) => Next::Close,
            Fault::Garbage(k, text) if at == Some(k) => Next::Line(text.to_string()),
            Fault::Always(text) if at.is_some() => Next::Line(text.to_string()),
            Fault::Silent if at.is_some() => Next::Skip,
            _ => Next::Line(line_of(&q)),
        }
    })
}

/// A BNO055 far end: acknowledges the mode writes, answers CALIB_STAT with `calib` and every
/// quaternion read with the plant's orientation, until `done`; returns the requests.
fn bno055(
    mut port: TTYPort,
    plant: Shared,
    calib: u8,
    done: Arc<AtomicBool>,
) -> JoinHandle<Vec<Vec<u8>>> {
    std::thread::spawn(move || {
        port.set_timeout(Duration::from_millis(20)).unwrap();
        let (mut requests, mut got, start) = (Vec::new(), Vec::new(), Instant::now());
        let mut buf = [0u8; 64];
        loop {
            assert!(start.elapsed() < GUARD, "the BNO055 never told to stop");
            match port.read(&mut buf) {
                Ok(n) => got.extend_from_slice(&buf[..n]),
                Err(_) if done.load(Ordering::SeqCst) => return requests,
                Err(_) => continue,
            }
            let need = if got.get(1) == Some(&0x00) { 5 } else { 4 };
            if got.len() < need {
                continue;
            }
            let req: Vec<u8> = got.drain(..need).collect();
            let reply = if req[1] == 0x00 {
                vec![0xEE, 0x01]
            } else if req[2] == 0x35 {
                vec![0xBB, 0x01, calib]
            } else {
                let q = plant.lock().unwrap().now();
                let mut r = vec![0xBB, 0x08];
                for c in [q.w, q.i, q.j, q.k] {
                    r.extend(((c * 16384.0).round() as i16).to_le_bytes());
                }
                r
            };
            requests.push(req);
            port.write_all(&reply).unwrap();
        }
    })
}

/// What one closed-loop replay gave.
struct Ran {
    result: Result<ClosedSummary, RigError>,
    text: String,
    frames: [Vec<u8>; 2],
    /// What the boards' far ends received, with when.
    received: [Received; 2],
    /// When `execute` returned.
    ended: Instant,
    log: String,
    /// The BNO055's requests (empty with quat-csv).
    requests: Vec<Vec<u8>>,
    sensor_path: String,
}

/// Runs the closed loop of `inputs` on two LCUS boards and a sensor of `format` whose plant
/// follows `script`.
fn run(inputs: &ClosedInputs, script: Script, format: SensorFormat, fault: Fault) -> Ran {
    run_with(inputs, script, format, fault, Duration::from_millis(500))
}

/// [`run`] with the sensor timeout `timeout`.
fn run_with(
    inputs: &ClosedInputs,
    script: Script,
    format: SensorFormat,
    fault: Fault,
    timeout: Duration,
) -> Ran {
    let plant = Ball::shared(script, inputs.open.rows[0].q, None);
    let done = Arc::new(AtomicBool::new(false));
    let (b0, c0) = pty();
    let (b1, c1) = pty();
    let (s_far, s_near) = pty();
    let boards = [
        board(b0, 0, plant.clone(), done.clone()),
        board(b1, 1, plant.clone(), done.clone()),
    ];
    let sensor_path = path_of(&s_near);
    let (far_q, far_b) = match format {
        SensorFormat::QuatCsv => (
            Some(printer(s_far, plant.clone(), fault, done.clone())),
            None,
        ),
        SensorFormat::Bno055 => {
            let calib = match fault {
                Fault::Calibration(c) => c,
                _ => 0xFF,
            };
            (
                None,
                Some(bno055(s_far, plant.clone(), calib, done.clone())),
            )
        }
    };
    let near = Box::new(s_near.try_clone_native().unwrap());
    let sensor = sensor::from_port(format, near, &sensor_path, timeout).unwrap();
    let link = |c: &TTYPort| {
        let port = Box::new(c.try_clone_native().unwrap());
        Link::from_port(port, &path_of(c), Duration::from_secs(5))
    };
    let mut out = Vec::new();
    let stop = Arc::new(AtomicBool::new(false));
    let result = execute(inputs, vec![link(&c0), link(&c1)], sensor, stop, &mut out);
    let ended = Instant::now();
    done.store(true, Ordering::SeqCst);
    let received = boards.map(|h| h.join().unwrap());
    let frames = received.clone().map(|(bytes, _)| bytes);
    if let Some(h) = far_q {
        h.join().unwrap();
    }
    let requests = far_b.map(|h| h.join().unwrap()).unwrap_or_default();
    // no log when the replay was refused before it began
    let log = std::fs::read_to_string(inputs.prep.drive.log.as_ref().unwrap()).unwrap_or_default();
    Ran {
        result: result.map_err(|e| match e {
            spherestep::Error::Rig(r) => r,
            other => panic!("expected the rig's error, got: {other}"),
        }),
        text: String::from_utf8_lossy(&out).into_owned(),
        frames,
        received,
        ended,
        log,
        requests,
        sensor_path,
    }
}

/// The sets of a script.
fn sets(script: &Script) -> Vec<BTreeSet<usize>> {
    script.iter().map(|(s, _)| s.clone()).collect()
}

/// The log's sensor rows: (step, w, x, y, z).
fn sensor_rows(log: &str) -> Vec<(usize, [f64; 4])> {
    log.lines()
        .filter(|l| l.split(',').nth(2) == Some("sensor"))
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            let q = [7, 8, 9, 10].map(|i| c[i].parse::<f64>().unwrap());
            (c[1].parse().unwrap(), q)
        })
        .collect()
}

fn prepared(dir: &Path, format: SensorFormat) -> ClosedInputs {
    let plan = plan_file(dir);
    let so = SensorOptions::new("/dev/sensor-given-by-the-test", format);
    prepare_closed(&options(dir, &plan), &so).unwrap()
}

/// The coils of a plan's rows.
fn coils_of(inputs: &ClosedInputs) -> BTreeSet<usize> {
    let rows = &inputs.open.rows;
    rows.iter()
        .flat_map(|r| r.active.iter().map(|p| p.coil.0))
        .collect()
}

#[test]
fn closed_loop_as_predicted_switches_the_plan_and_replans_nothing() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let inputs = prepared(dir.path(), SensorFormat::QuatCsv);
    let (script, replans) = offline(&inputs, None);
    assert_eq!(replans, 0);
    assert_eq!(script.len(), inputs.open.rows.len());
    let ran = run(&inputs, script.clone(), SensorFormat::QuatCsv, Fault::None);
    let s = ran.result.unwrap_or_else(|e| panic!("{e}\n{}", ran.text));
    assert_eq!((s.steps, s.replans), (script.len() - 1, 0));
    assert!(s.distance_deg < 1e-6, "{s:?}");
    assert_eq!(ran.frames, expected_frames(&sets(&script)), "{}", ran.text);
    // the log: a sensor row per step with what the plant reported, no replan
    let header = "t_s,step,action,coil,board,channel,bytes,qw,qx,qy,qz,goal_deg,raw";
    assert!(ran.log.starts_with(&format!("{header}\n")), "{}", ran.log);
    let rows = sensor_rows(&ran.log);
    assert_eq!(rows.len(), script.len());
    for (k, (step, q)) in rows.iter().enumerate() {
        let e = script[k].1;
        assert_eq!(*step, k);
        assert_eq!(*q, [e.w, e.i, e.j, e.k], "step {k}");
    }
    assert!(ran
        .log
        .contains(&format!(",\"{}\"\n", line_of(&script[0].1))));
    assert!(!ran.log.contains(",replan,"), "{}", ran.log);
    assert!(ran.log.contains(",goal,"), "{}", ran.log);
    assert!(
        ran.text.starts_with("closed loop: quat-csv sensor on "),
        "{}",
        ran.text
    );
    assert!(ran.text.contains(" 0 sensor   ["), "{}", ran.text);
    assert!(
        ran.text.ends_with(&format!(
            "closed loop done: at the goal after {} step(s), 0 replan(s); the last measurement 0.00 deg from the goal; all coils off\n",
            script.len() - 1
        )),
        "{}",
        ran.text
    );
}

#[test]
fn closed_loop_replans_when_the_measurement_strays() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let inputs = prepared(dir.path(), SensorFormat::QuatCsv);
    let (script, replans) = offline(&inputs, Some(2));
    assert!(replans >= 1);
    // the new plan is not the old one's rest
    let open: Vec<BTreeSet<usize>> = inputs
        .open
        .rows
        .iter()
        .map(|r| r.active.iter().map(|p| p.coil.0).collect())
        .collect();
    assert_ne!(sets(&script), open);
    let ran = run(&inputs, script.clone(), SensorFormat::QuatCsv, Fault::None);
    let s = ran.result.unwrap_or_else(|e| panic!("{e}\n{}", ran.text));
    assert_eq!((s.steps, s.replans), (script.len() - 1, replans));
    assert_eq!(ran.frames, expected_frames(&sets(&script)), "{}", ran.text);
    let rows = sensor_rows(&ran.log);
    assert_eq!(rows.len(), script.len());
    let strayed = script[2].1;
    assert_eq!(rows[2].1, [strayed.w, strayed.i, strayed.j, strayed.k]);
    let replan_rows: Vec<&str> = ran.log.lines().filter(|l| l.contains(",replan,")).collect();
    assert_eq!(replan_rows.len(), replans);
    assert_eq!(replan_rows[0].split(',').nth(1), Some("2"), "{}", ran.log);
    assert!(ran.text.contains(" 2 sensor   ["), "{}", ran.text);
    assert!(ran.text.contains("4.00 deg from the plan"), "{}", ran.text);
    assert!(ran.text.contains("    2 replan   "), "{}", ran.text);
}

#[test]
fn closed_loop_refuses_a_replan_that_uses_an_unmapped_coil_before_switching_it() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let all = prepared(dir.path(), SensorFormat::QuatCsv);
    let (script, _) = offline(&all, Some(2));
    // map only the open plan's coils (where the laid map puts them)
    let used = coils_of(&all);
    let k = (3..script.len()).find(|&k| !script[k].0.is_subset(&used));
    let k = k.expect("the replanned plan switches a coil the open plan does not use");
    let map: String = used
        .iter()
        .map(|c| format!("{c} = \"{}:{}\"\n", c / 8, c % 8 + 1))
        .collect();
    let mut opts = options(dir.path(), &dir.path().join("plan.csv"));
    let partial = dir.path().join("partial.toml");
    std::fs::write(&partial, format!("{TWO_LCUS}[map]\n{map}")).unwrap();
    opts.map = Some(partial);
    let so = SensorOptions::new("/dev/sensor-given-by-the-test", SensorFormat::QuatCsv);
    let inputs = prepare_closed(&opts, &so).unwrap();
    let ran = run(&inputs, script.clone(), SensorFormat::QuatCsv, Fault::None);
    let e = ran.result.as_ref().map(|_| ()).unwrap_err().to_string();
    assert!(
        e.starts_with(&format!(
            "the plan replanned after step 2 (replan 1) is refused before switching anything of it: plan step {k} uses coil "
        )) && e.contains(", which no relay channel drives"),
        "{e}"
    );
    assert!(
        e.contains("; all coils switched off (closed loop: 2 step(s), 1 replan(s)"),
        "{e}"
    );
    // steps 0..=2 switched, nothing of the new plan, then all off on both boards
    assert_eq!(
        ran.frames,
        expected_frames(&sets(&script)[..3]),
        "{}",
        ran.text
    );
    assert!(!ran.log.contains(",replan,"), "{}", ran.log);
}

#[test]
fn closed_loop_refuses_dry_run_and_bad_sensor_options() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let plan = plan_file(dir.path());
    let mut opts = options(dir.path(), &plan);
    let so = SensorOptions::new("/dev/ttyACM0", SensorFormat::QuatCsv);
    let err = |opts: &ReplayOptions, so: &SensorOptions| {
        Flagged(prepare_closed(opts, so).err().expect("refused")).to_string()
    };
    opts.dry_run = true;
    assert!(err(&opts, &so).starts_with("argument --dry-run: expected none with a sensor"));
    opts.dry_run = false;
    opts.ports = vec!["/dev/ttyUSB0".into(), "/dev/ttyACM0".into()];
    assert_eq!(
        err(&opts, &so),
        "argument --sensor: expected the sensor's own serial device, got /dev/ttyACM0, board 1's port"
    );
    opts.ports.clear();
    let bad = SensorOptions {
        timeout_ms: Some(0),
        ..so.clone()
    };
    assert!(err(&opts, &bad).starts_with("argument --sensor-timeout-ms"));
    // the coils stay on while the sensor is awaited: its timeout is under their on-time limit
    // (10 s here)
    for ms in [10_000, 15_000, 100_000, u64::MAX] {
        let long = SensorOptions {
            timeout_ms: Some(ms),
            ..so.clone()
        };
        assert_eq!(
            err(&opts, &long),
            format!(
                "argument --sensor-timeout-ms: expected a timeout shorter than relay.max_on_time_s \
                 (10000 ms: the coils stay on while the sensor is awaited), got {ms} ms"
            )
        );
    }
    let under = SensorOptions {
        timeout_ms: Some(9_999),
        ..so.clone()
    };
    assert!(prepare_closed(&opts, &under).is_ok());
    let mode = SensorOptions {
        mode: Some(FusionMode::Ndof),
        ..so.clone()
    };
    assert_eq!(
        err(&opts, &mode),
        "argument --sensor-mode: expected no --sensor-mode with a quat-csv sensor (the mode is \
         the BNO055's; the sketch behind a quat-csv port chooses its own fusion), got ndof"
    );
    let noisy = SensorOptions {
        noise_deg: 90.0,
        ..so
    };
    assert!(err(&opts, &noisy).contains("--sensor-noise-deg"));
}

#[test]
fn closed_loop_refuses_a_log_of_another_kind_before_opening_anything() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let plan = plan_file(dir.path());
    let mut opts = options(dir.path(), &plan);
    let so = SensorOptions::new("/dev/ttyACM0", SensorFormat::QuatCsv);
    let log = dir.path().join("replay.csv");
    // the plan itself, and a replay's log (without the sensor's columns)
    std::fs::write(&log, "t_s,step,action,coil,board,channel,bytes\n").unwrap();
    for (file, says) in [
        (&plan, "its first line is `step,pivot_coil,"),
        (&log, "a replay's log without the sensor's columns"),
    ] {
        let before = std::fs::read(file).unwrap();
        opts.log = Some(file.clone());
        let e = prepare_closed(&opts, &so)
            .err()
            .expect("refused")
            .to_string();
        assert!(e.starts_with(&format!("log {}: ", file.display())), "{e}");
        assert!(e.contains(says), "{e}");
        assert_eq!(std::fs::read(file).unwrap(), before);
    }
    // a closed loop's own log is fine
    std::fs::write(
        &log,
        "t_s,step,action,coil,board,channel,bytes,qw,qx,qy,qz,goal_deg,raw\n",
    )
    .unwrap();
    opts.log = Some(log);
    assert!(prepare_closed(&opts, &so).is_ok());
}

#[test]
fn closed_loop_on_a_bno055_reads_after_every_step() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let inputs = prepared(dir.path(), SensorFormat::Bno055);
    let (script, _) = offline(&inputs, None);
    let ran = run(&inputs, script.clone(), SensorFormat::Bno055, Fault::None);
    let s = ran.result.unwrap_or_else(|e| panic!("{e}\n{}", ran.text));
    assert_eq!((s.steps, s.replans), (script.len() - 1, 0));
    assert!(s.distance_deg < 0.05, "{s:?}");
    assert_eq!(ran.frames, expected_frames(&sets(&script)), "{}", ran.text);
    // CONFIGMODE, then IMU (no magnetometer: it would read the motor's magnets), the
    // calibration status, the tare's reading, then a reading after every step
    let mut want = vec![
        vec![0xAA, 0x00, 0x3D, 0x01, 0x00],
        vec![0xAA, 0x00, 0x3D, 0x01, 0x08],
        vec![0xAA, 0x01, 0x35, 0x01],
    ];
    want.extend((0..=script.len()).map(|_| vec![0xAA, 0x01, 0x20, 0x08]));
    assert_eq!(ran.requests, want);
    // the raw frames in the log, in hex
    let rows: Vec<&str> = ran.log.lines().filter(|l| l.contains(",sensor,")).collect();
    assert_eq!(rows.len(), script.len());
    assert!(
        rows.iter()
            .all(|l| l.ends_with('"') && l.contains(",\"BB 08 ")),
        "{}",
        ran.log
    );
    assert!(
        ran.text
            .starts_with(
                "sensor calibration: system 3, gyroscope 3, accelerometer 3, magnetometer 3 (of 3)\nclosed loop: BNO055 (UART, IMU mode) on "
            ),
        "{}",
        ran.text
    );
}

/// A fault at script entry 2: steps 0..=2 switched, then every coil off on both boards.
fn faulty(fault: Fault) -> (Ran, String) {
    let dir = tempfile::tempdir().unwrap();
    let inputs = prepared(dir.path(), SensorFormat::QuatCsv);
    let (script, _) = offline(&inputs, None);
    let ran = run(&inputs, script.clone(), SensorFormat::QuatCsv, fault);
    let e = match &ran.result {
        Ok(s) => panic!("the replay went on: {s:?}\n{}", ran.text),
        Err(e) => e.to_string(),
    };
    // the sensor's error arrives as the sensor's, inside the loop's stop
    assert!(
        matches!(&ran.result, Err(RigError::LoopStopped { cause, .. })
            if matches!(**cause, RigError::Sensor(_))),
        "{e}"
    );
    assert_eq!(
        ran.frames,
        expected_frames(&sets(&script)[..3]),
        "{}",
        ran.text
    );
    assert_eq!(sensor_rows(&ran.log).len(), 2, "{}", ran.log);
    assert!(
        e.contains("; all coils switched off (closed loop: 2 step(s), 0 replan(s)"),
        "{e}"
    );
    (ran, e)
}

#[test]
fn closed_loop_sensor_closed_mid_run_switches_everything_off() {
    let _one = crate::one_at_a_time();
    let (ran, e) = faulty(Fault::Close(2));
    let p = &ran.sensor_path;
    assert!(
        e.starts_with(&format!(
            "sensor {p} (quat-csv): the sensor end closed the connection while reading"
        )),
        "{e}"
    );
}

#[test]
fn closed_loop_sensor_garbage_switches_everything_off() {
    let _one = crate::one_at_a_time();
    let (ran, e) = faulty(Fault::Garbage(2, "hello there"));
    let p = &ran.sensor_path;
    assert!(
        e.starts_with(&format!(
            "sensor {p} (quat-csv): garbage line 'hello there': "
        )),
        "{e}"
    );
}

/// Inputs whose boards allow each coil `max_on_time_s`, with the sensor's `timeout_ms`.
fn limited(dir: &Path, max_on_time_s: f64, timeout_ms: u64) -> ClosedInputs {
    let plan = plan_file(dir);
    let mut opts = options(dir, &plan);
    let map = dir.join("boards.toml");
    std::fs::write(&map, format!("max_on_time_s = {max_on_time_s}\n{TWO_LCUS}")).unwrap();
    opts.map = Some(map);
    let mut so = SensorOptions::new("/dev/sensor-given-by-the-test", SensorFormat::QuatCsv);
    so.timeout_ms = Some(timeout_ms);
    prepare_closed(&opts, &so).unwrap()
}

/// A closed-loop replay that ran into the on-time limit in `phase`: every coil went off
/// before its limit (as the boards' far ends saw it), the error says so, and the replay ended
/// soon after the all-off (the reading or the replan was abandoned, not waited for).
fn switched_off_before_the_limit(ran: &Ran, limit: Duration, phase: &str) {
    let e = match &ran.result {
        Ok(s) => panic!("the replay went on: {s:?}\n{}", ran.text),
        Err(e) => e,
    };
    let Err(RigError::LoopStopped { cause, .. }) = &ran.result else {
        panic!("{e}");
    };
    assert!(
        matches!(&**cause, RigError::Relay(RelayError::OnTimeReached { phase: p, .. })
            if p.ends_with(phase)),
        "{e}\n{}",
        ran.text
    );
    let text = e.to_string();
    assert!(
        text.contains(&format!("while the closed loop was {phase}")),
        "{text}"
    );
    let on = longest_on(&ran.received, ran.ended);
    // the margin the guard kept, printed for docs/safety.md (`-- --nocapture`)
    eprintln!("{phase}: the coil on longest went off {on:?} into a {limit:?} limit");
    assert!(
        on < limit,
        "a coil was on {on:?}, over {limit:?}\n{}",
        ran.text
    );
    // both boards end all off
    for f in &ran.frames {
        assert!(f.ends_with(&lcus_all_off(8)), "{f:02X?}");
    }
    let off_at = ran
        .received
        .iter()
        .map(|(_, t)| *t.last().unwrap())
        .max()
        .unwrap();
    assert!(
        ran.ended.saturating_duration_since(off_at) < Duration::from_secs(1),
        "the replay ended {:?} after the all-off",
        ran.ended.saturating_duration_since(off_at)
    );
}

#[test]
fn closed_loop_switches_off_before_the_on_time_limit_while_the_sensor_is_silent() {
    let _one = crate::one_at_a_time();
    // 1 s of on-time; step 0's dwell (0.1 s) and a sensor timeout of 0.95 s would end 1.05 s
    // after step 0's coils went on
    let dir = tempfile::tempdir().unwrap();
    let inputs = limited(dir.path(), 1.0, 950);
    let (script, _) = offline(&inputs, None);
    let timeout = Duration::from_millis(950);
    let ran = run_with(
        &inputs,
        script,
        SensorFormat::QuatCsv,
        Fault::Silent,
        timeout,
    );
    switched_off_before_the_limit(&ran, Duration::from_secs(1), "waiting for the sensor");
}

#[test]
fn closed_loop_switches_off_before_the_on_time_limit_while_it_replans() {
    let _one = crate::one_at_a_time();
    // a sensor that reads 180 degrees about Z whatever the ball does, and replans from there
    // searched 1024 states wide (256 times the default: tens of seconds in the broad wells,
    // where the default takes a few hundred milliseconds; 64 wide, a replan on an idle machine
    // could end within the limit, and its plan was then refused instead); the coils are
    // allowed 1 s, and the replan is abandoned when the limit comes
    let dir = tempfile::tempdir().unwrap();
    let mut inputs = limited(dir.path(), 1.0, 500);
    let (script, _) = offline(&inputs, None);
    inputs.cl.replan_beam = 1024;
    let far = Fault::Always("0,0,0,1");
    let ran = run(&inputs, script, SensorFormat::QuatCsv, far);
    switched_off_before_the_limit(
        &ran,
        Duration::from_secs(1),
        "deciding (fitting the wells, replanning)",
    );
    // every reading was taken and logged before the coils went off (the far reading is
    // replanned from, and the next decision is where the limit comes)
    let rows = sensor_rows(&ran.log);
    assert!(!rows.is_empty(), "{}", ran.log);
    assert!(
        rows.iter()
            .enumerate()
            .all(|(k, r)| *r == (k, [0.0, 0.0, 0.0, 1.0])),
        "{}",
        ran.log
    );
}

#[test]
fn the_hardware_loop_takes_the_decisions_of_the_simulated_one() {
    let _one = crate::one_at_a_time();
    // one loop function drives both plants: the simulated run of the broad-well plan on the
    // worn plant (1 deg of seeded sensor noise), then the same measurements reported by the
    // pseudo-terminal sensor as each set goes on: the same sets switched, replans at the same
    // steps, the same ending
    let dir = tempfile::tempdir().unwrap();
    let inputs = prepared(dir.path(), SensorFormat::QuatCsv);
    let worn = Scenario::load(Path::new("scenarios/plants/broad-wells-worn.toml")).unwrap();
    let model = inputs.scenario.motor();
    // the controller's thresholds are those of a noiseless sensor (replan beyond 1 deg), the
    // simulated sensor's noise 1 deg: measurements stray, and the loop replans
    let cl = LoopSettings {
        noise: Radians(1f64.to_radians()),
        seed: 3,
        ..inputs.cl
    };
    let sim = run_closed_loop(
        &model,
        &worn.motor(),
        &inputs.settings,
        &inputs.open,
        inputs.goal,
        &cl,
    );
    assert!(sim.summary.reached, "{:?}", sim.summary);
    assert!(sim.summary.replans > 0, "{:?}", sim.summary);
    let script: Script = sim
        .rows
        .iter()
        .map(|r| {
            let coils = r.active.iter().map(|p| p.coil.0).collect();
            // as the far end prints it and the replay decodes it
            (coils, parse_line(&line_of(&r.measured)).unwrap())
        })
        .collect();
    for w in script.windows(2) {
        assert_ne!(
            w[0].0, w[1].0,
            "the far end tells steps apart by their sets"
        );
    }
    let ran = run(&inputs, script.clone(), SensorFormat::QuatCsv, Fault::None);
    let s = ran.result.unwrap_or_else(|e| panic!("{e}\n{}", ran.text));
    assert_eq!(ran.frames, expected_frames(&sets(&script)), "{}", ran.text);
    assert_eq!(s.steps, sim.summary.steps);
    assert_eq!(s.replans, sim.summary.replans);
    let replanned_at: Vec<usize> = ran
        .log
        .lines()
        .filter(|l| l.split(',').nth(2) == Some("replan"))
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    let sim_replanned: Vec<usize> = sim
        .rows
        .iter()
        .filter(|r| r.replanned)
        .map(|r| r.step)
        .collect();
    assert_eq!(replanned_at, sim_replanned, "{}", ran.log);
}

#[test]
fn closed_loop_refuses_a_bno055_whose_gyroscope_is_uncalibrated_before_any_switching() {
    let _one = crate::one_at_a_time();
    // CALIB_STAT 0xCF: system 3, gyroscope 0, accelerometer 3, magnetometer 3
    let dir = tempfile::tempdir().unwrap();
    let inputs = prepared(dir.path(), SensorFormat::Bno055);
    let (script, _) = offline(&inputs, None);
    let ran = run(
        &inputs,
        script,
        SensorFormat::Bno055,
        Fault::Calibration(0xCF),
    );
    let e = ran.result.expect_err("refused").to_string();
    assert_eq!(
        e,
        format!(
            "sensor {} (bno055): the gyroscope is not calibrated (system 3, gyroscope 0, \
             accelerometer 3, magnetometer 3 (of 3)): keep the ball still for a few seconds \
             with every coil off, then start again",
            ran.sensor_path
        )
    );
    // no byte went to either board
    assert_eq!(ran.frames, [Vec::<u8>::new(), Vec::new()]);
    assert_eq!(ran.requests.last().unwrap(), &vec![0xAA, 0x01, 0x35, 0x01]);
}
