//! `replay --sensor` through the virtual motor takes the decisions `run --closed-loop` takes
//! with the same plant and seed: the same coils on at each step, replanned after the same
//! steps, up to where the two loops' goals part (see the test). The plant is the prototype with every coil pulling every magnet in reach (the model
//! pairs each coil with one magnet), so the loop must replan. Written against the closed loop
//! as it is (its controller is being reworked): where they part, this test says at which step.
//! The virtual clock runs 20 times the wall clock and the replay's dwells and floor are 5 times
//! shorter than the defaults, so the ball has four times the dwells it needs on the virtual
//! clock and is at rest when measured, as in `run`; the on-time limit is lifted (the replans'
//! wall time counts while the coils are on, and the limit is not what this test is about; the
//! run and the replay plan with the same limits, from the same file). Nothing asserts how fast
//! anything ran.
#![cfg(unix)]

mod common;

use std::collections::BTreeSet;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const GUARD: Duration = Duration::from_secs(300);

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

/// Coil sets per step and the steps replanned after, from `run`'s CSV.
fn from_run(csv: &str) -> (Vec<BTreeSet<usize>>, Vec<usize>) {
    let mut lines = csv.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| head.iter().position(|h| *h == n).unwrap();
    let (a, r, s) = (col("active"), col("replanned"), col("step"));
    let (mut sets, mut replans) = (Vec::new(), Vec::new());
    for l in lines {
        let f: Vec<&str> = l.split(',').collect();
        let set = f[a]
            .split(';')
            .filter(|p| !p.is_empty())
            .map(|p| p.split(':').next().unwrap().parse().unwrap())
            .collect();
        sets.push(set);
        if f[r] == "true" {
            replans.push(f[s].parse().unwrap());
        }
    }
    (sets, replans)
}

/// The same from the replay's closed-loop log (`t_s,step,action,coil,channel,...`).
fn from_replay_log(csv: &str) -> (Vec<BTreeSet<usize>>, Vec<usize>) {
    let mut on: BTreeSet<usize> = BTreeSet::new();
    let mut sets: Vec<BTreeSet<usize>> = Vec::new();
    let mut replans = Vec::new();
    for l in csv.lines().skip(1) {
        let f: Vec<&str> = l.split(',').collect();
        let (step, action) = (f[1], f[2]);
        match action {
            "on" => {
                on.insert(f[3].parse().unwrap());
            }
            "off" => {
                on.remove(&f[3].parse::<usize>().unwrap());
            }
            "done" => {
                let k: usize = step.parse().unwrap();
                if sets.len() == k {
                    sets.push(on.clone());
                }
            }
            "replan" => replans.push(step.parse().unwrap()),
            _ => {}
        }
    }
    (sets, replans)
}

#[test]
fn replay_through_the_virtual_motor_decides_as_run_closed_loop() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let model = write(
        d,
        "model.toml",
        "name = \"model\"\n[relay]\nboard = \"numato\"\ndwell_factor = 0.3\ndwell_floor_ms = 40\nmax_on_time_s = 1000\n",
    );
    let plant = write(
        d,
        "plant.toml",
        "name = \"plant\"\n[magnets]\ninteraction = \"coils\"\n[relay]\nboard = \"numato\"\nmax_on_time_s = 1000\n",
    );
    let plan = d.join("plan.csv").display().to_string();
    let target = ["--axis", "0,0,1", "--angle", "90"];
    let (code, out, err) =
        common::run(&[&["plan", &model][..], &target, &["--out", &plan]].concat());
    assert_eq!(code, 0, "{out}{err}");
    let run_csv = d.join("run.csv").display().to_string();
    let (_, out, err) = common::run(
        &[
            &[
                "run",
                &model,
                "--plant",
                &plant,
                "--closed-loop",
                "--seed",
                "7",
            ][..],
            &target,
            &["--out", &run_csv],
        ]
        .concat(),
    );
    let run = std::fs::read_to_string(&run_csv).unwrap_or_else(|_| panic!("{out}{err}"));

    let links = d.join("dev");
    let links_s = links.display().to_string();
    let mut v = Command::new(common::bin())
        .args([
            "virtual",
            &plant,
            "--speed",
            "20",
            "--sensor",
            "quat-csv",
            "--seed",
            "7",
            "--link-dir",
            &links_s,
            "--plan",
            &plan,
            "--max-seconds",
            "250",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(v.stdout.take().unwrap()).lines();
    let deadline = Instant::now() + GUARD;
    loop {
        assert!(
            Instant::now() < deadline,
            "the virtual motor never got ready"
        );
        match lines.next() {
            Some(Ok(l)) if l.starts_with("ready:") => break,
            Some(Ok(_)) => {}
            _ => panic!("the virtual motor ended before it was ready"),
        }
    }
    std::thread::spawn(move || for _ in lines.by_ref() {});
    let log = d.join("replay.csv").display().to_string();
    let board = links.join("board0").display().to_string();
    let sensor = links.join("sensor").display().to_string();
    let mut r = Command::new(common::bin())
        .args([
            "replay",
            &plan,
            &model,
            "--port",
            &board,
            "--sensor",
            &sensor,
            "--sensor-format",
            "quat-csv",
            "--log",
            &log,
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let status = loop {
        if let Some(s) = r.try_wait().unwrap() {
            break s;
        }
        if Instant::now() > deadline {
            let _ = r.kill();
            let _ = v.kill();
            panic!("the replay did not end in time");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let replay_out = r.wait_with_output().unwrap();
    let said = format!(
        "{status}\n{}\n{}",
        String::from_utf8_lossy(&replay_out.stdout),
        String::from_utf8_lossy(&replay_out.stderr)
    );
    let vend = Instant::now() + Duration::from_secs(30);
    while v.try_wait().unwrap().is_none() {
        if Instant::now() > vend {
            let _ = v.kill();
            break;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let replay_log = std::fs::read_to_string(&log).unwrap_or_default();
    let (run_sets, run_replans) = from_run(&run);
    let (replay_sets, replay_replans) = from_replay_log(&replay_log);
    assert!(
        !run_replans.is_empty(),
        "the plant is the model's: nothing to replan\n{run}"
    );
    // As the closed loop is today, the two agree up to the first step planned in the fitted
    // wells (step 2 here), and part there: `run` steers towards ROT[axis, angle] applied to
    // row 0 (90 degrees about Z), `replay --sensor` towards the plan file's last row (91.65
    // degrees). The steps before it and the replans after steps 0 and 1 are the same.
    let agreed = 2;
    for (k, a) in run_sets.iter().enumerate().take(agreed) {
        let b = replay_sets.get(k);
        assert_eq!(
            Some(a),
            b,
            "step {k}: run switched {a:?}, the replay {b:?}\n{said}"
        );
    }
    let before = |v: &[usize]| {
        v.iter()
            .copied()
            .filter(|&k| k < agreed)
            .collect::<Vec<_>>()
    };
    assert_eq!(before(&run_replans), before(&replay_replans), "{said}");
    assert_eq!(before(&run_replans), vec![0, 1], "{run}");
}
