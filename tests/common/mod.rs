//! Helpers shared by the integration tests.
#![allow(dead_code)]

use nalgebra::UnitQuaternion;
use spherestep::io::scenario::Scenario;
use spherestep::model::geometry::{CoilId, MagnetId, Orientation};

/// The magnet nearest to coil `coil` at orientation `q`, and its distance (radians).
pub fn nearest_magnet(sc: &Scenario, coil: usize, q: &Orientation) -> (MagnetId, f64) {
    let (m, d) = spherestep::planning::commutation::nearest_magnet(&sc.torques, CoilId(coil), q);
    (m, d.0)
}

pub fn identity() -> Orientation {
    UnitQuaternion::identity()
}

/// Path of the built binary.
pub fn bin() -> std::path::PathBuf {
    std::path::PathBuf::from(env!("CARGO_BIN_EXE_spherestep"))
}

/// Runs the binary: exit code (-1 if killed), standard output and standard error.
pub fn run(args: &[&str]) -> (i32, String, String) {
    let out = std::process::Command::new(bin())
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Runs `spherestep batch ARGS`.
pub fn batch(args: &[&str]) -> std::process::Output {
    std::process::Command::new(bin())
        .arg("batch")
        .args(args)
        .output()
        .unwrap()
}

/// A plan's CSV bytes, as `plan --out` writes them.
pub fn csv_bytes(p: &spherestep::planning::planner::Plan) -> Vec<u8> {
    let mut b = Vec::new();
    spherestep::io::planfile::write_plan(&p.rows, &mut b).unwrap();
    b
}

/// The worst angle, degrees, from any of `qs` to `samples` + 1 points of the slerp from `a` to
/// `b` (sampled: an independent check of `spherestep::model::geometry::distance_to_geodesic`).
pub fn sampled_path_deviation_deg(
    qs: &[Orientation],
    a: &Orientation,
    b: &Orientation,
    samples: usize,
) -> f64 {
    let a4 = a.quaternion().coords;
    let b4 = match a4.dot(&b.quaternion().coords) < 0.0 {
        true => -b.quaternion().coords,
        false => b.quaternion().coords,
    };
    let path: Vec<Orientation> = (0..=samples)
        .map(|k| {
            let t = k as f64 / samples as f64;
            let p = a4 * (1.0 - t) + b4 * t; // along the chord, then onto the sphere
            let theta = a4.dot(&b4).clamp(-1.0, 1.0).acos();
            let p = match theta < 1e-12 {
                true => p,
                false => (a4 * ((1.0 - t) * theta).sin() + b4 * (t * theta).sin()) / theta.sin(),
            };
            UnitQuaternion::from_quaternion(nalgebra::Quaternion::from(p))
        })
        .collect();
    qs.iter()
        .map(|q| {
            path.iter()
                .map(|p| q.angle_to(p))
                .fold(f64::INFINITY, f64::min)
                .to_degrees()
        })
        .fold(0.0, f64::max)
}

/// Replay's own check of a plan's rows in `sc` (the dry run's, before any byte is sent): every
/// coil mapped on a 16-channel Numato board, coils on at once counting the transitions, and
/// each coil's continuous on-time within `relay.max_on_time_s`, realtime, with the plan's
/// dwells.
pub fn replay_check(
    sc: &Scenario,
    rows: &[spherestep::PlanRow],
) -> Result<spherestep::relay::replay::Schedule, spherestep::relay::RelayError> {
    use spherestep::relay::replay::{schedule, Mode};
    let board = spherestep::relay::BoardKind::Numato;
    let stator = sc.stator.points.len();
    schedule(rows, &sc.relay, board, 16, stator, None, 0, Mode::Realtime)
}

/// Every file below `dir`, at any depth (folders left out), sorted.
pub fn files_below(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The relay tests' harness: plans, scenarios, pseudo-terminal pairs and the boards' far ends.
#[cfg(unix)]
pub mod relay_support;

/// The closed loop's scripted plant on pseudo-terminals: the controller run offline through the
/// library's loop, and the ball the boards' far ends switch.
#[cfg(unix)]
pub mod scripted;

/// `spherestep plan SCENARIO --excite STEPS --seed SEED --json --out OUT`, which must succeed:
/// its summary.
pub fn excite(scenario: &str, steps: &str, seed: &str, out: &std::path::Path) -> serde_json::Value {
    let args = [
        "plan", scenario, "--excite", steps, "--seed", seed, "--json", "--out",
    ];
    let (code, stdout, err) = run(&[&args[..], &[out.to_str().unwrap()]].concat());
    assert_eq!(code, 0, "{stdout}{err}");
    serde_json::from_str(stdout.trim()).unwrap_or_else(|e| panic!("{e}: {stdout}{err}"))
}

/// Starts `spherestep virtual PLANT` with its boards and a quat-csv sensor of `noise_deg`
/// (seed 7) linked in `links`, at rest at `plan`'s start, its clock `speed` times the wall
/// clock, and waits, until `deadline`, for its `ready:` line; from then on its standard output
/// is drained on a thread (its standard error is dropped).
pub fn start_virtual(
    plant: &str,
    plan: &str,
    links: &std::path::Path,
    (speed, noise_deg): (&str, &str),
    deadline: std::time::Instant,
) -> std::process::Child {
    use std::io::BufRead;
    use std::process::{Command, Stdio};
    let links = links.display().to_string();
    let mut v = Command::new(bin())
        .arg("virtual")
        .args([
            plant,
            "--speed",
            speed,
            "--sensor",
            "quat-csv",
            "--sensor-noise-deg",
        ])
        .args([
            noise_deg,
            "--seed",
            "7",
            "--link-dir",
            &links,
            "--plan",
            plan,
        ])
        .args(["--max-seconds", "250"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut lines = std::io::BufReader::new(v.stdout.take().unwrap()).lines();
    loop {
        if std::time::Instant::now() >= deadline {
            let _ = v.kill();
            let _ = v.wait();
            panic!("the virtual motor never got ready");
        }
        match lines.next() {
            Some(Ok(l)) if l.starts_with("ready:") => break,
            Some(Ok(_)) => {}
            _ => panic!("the virtual motor ended before it was ready"),
        }
    }
    std::thread::spawn(move || for _ in lines.by_ref() {});
    v
}

/// `spherestep replay PLAN MODEL` on the boards and quat-csv sensor of the virtual motor `v`
/// (linked in `links`, as [`start_virtual`] starts it), dwelling `dwell_ms` a step, logging
/// to `log`, with `extra` arguments, until `deadline` (past it both are killed, and the test
/// fails): its exit status, standard output and standard error.
pub fn replay_beside(
    v: &mut std::process::Child,
    (plan, model): (&str, &str),
    links: &std::path::Path,
    (log, dwell_ms): (&str, &str),
    extra: &[&str],
    deadline: std::time::Instant,
) -> (std::process::ExitStatus, String, String) {
    use std::process::{Command, Stdio};
    let (board, sensor) = (links.join("board0"), links.join("sensor"));
    let (board, sensor) = (board.to_str().unwrap(), sensor.to_str().unwrap());
    let mut r = Command::new(bin())
        .args(["replay", plan, model, "--port", board, "--sensor", sensor])
        .args([
            "--sensor-format",
            "quat-csv",
            "--log",
            log,
            "--dwell-ms",
            dwell_ms,
        ])
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let status = loop {
        if let Some(s) = r.try_wait().unwrap() {
            break s;
        }
        if std::time::Instant::now() > deadline {
            let _ = r.kill();
            let _ = v.kill();
            let _ = (r.wait(), v.wait());
            panic!("the replay of {plan} did not end in time");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    };
    let out = r.wait_with_output().unwrap();
    (
        status,
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}
