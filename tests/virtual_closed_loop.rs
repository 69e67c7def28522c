//! `replay --sensor` through the virtual motor against the simulated closed loop with the same
//! plant and seed, the same plan file and so the same goal: the same coils on and the same
//! replans over the first steps (see the test for where and why they part later: issue 30 is
//! open there). The simulated loop is `simulate PLAN --plant PLANT --closed-loop`: a plan file
//! does not say where `plan` was asked to go (90 degrees about Z here; the plan's last row is
//! 91.65 degrees), so `replay --sensor` and `simulate` of the same file both aim at its last
//! row, where `run` aims at the asked target and parts from them once it replans towards it.
//! The plant is `cosine-35-coils` (cosine wells reaching 35 degrees, every coil pulling every
//! magnet in reach, half the stiffness; the model pairs each coil with one magnet in gaussian
//! wells), so the loop replans after every step; the fit of the wells is off in both. Every
//! step settles in that plant: a step that does not is measured at the settle's time limit in
//! the simulation and after the dwell on the virtual motor, which are other places. The sensor
//! is noiseless in both (the virtual sensor draws its noise per line it prints, the simulated
//! one per step: with noise their readings would be other samples). The virtual clock runs 20
//! times the wall clock and the replay dwells 400 ms a step, 8 s on the virtual clock (the
//! settle's own limit is 5 s), so the ball is at rest when measured, as in the simulation; the
//! on-time limit is lifted (the replans' wall time counts while the coils are on, and the limit
//! is not what this test is about). Nothing asserts how fast anything ran.
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

/// Coil sets per step and the steps replanned after, from `simulate`'s (or `run`'s) CSV.
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
fn replay_through_the_virtual_motor_decides_as_the_simulated_loop_over_the_first_steps() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let model = write(
        d,
        "model.toml",
        "name = \"model\"\n[relay]\nboard = \"numato\"\ndwell_factor = 0.3\ndwell_floor_ms = 40\nmax_on_time_s = 1000\n",
    );
    // cosine wells reaching 35 degrees, every coil pulling: every step settles in it, so the
    // ball is at rest when it is measured, in the simulation and on the virtual motor alike
    let wells = std::fs::read_to_string("scenarios/plants/cosine-35-coils.toml").unwrap();
    let plant = write(
        d,
        "plant.toml",
        &format!("{wells}\n[relay]\nboard = \"numato\"\nmax_on_time_s = 1000\n"),
    );
    let plan = d.join("plan.csv").display().to_string();
    let target = ["--axis", "0,0,1", "--angle", "90"];
    let (code, out, err) =
        common::run(&[&["plan", &model][..], &target, &["--out", &plan]].concat());
    assert_eq!(code, 0, "{out}{err}");
    // the simulated loop on the plan file, as the replay plays it
    let sim_csv = d.join("simulated.csv").display().to_string();
    let (sim_code, out, err) = common::run(&[
        "simulate",
        &plan,
        &model,
        "--plant",
        &plant,
        "--closed-loop",
        "--no-identify",
        "--sensor-noise-deg",
        "0",
        "--seed",
        "7",
        "--json",
        "--out",
        &sim_csv,
    ]);
    let sim = std::fs::read_to_string(&sim_csv).unwrap_or_else(|_| panic!("{out}{err}"));
    let summary: serde_json::Value =
        serde_json::from_str(out.trim()).unwrap_or_else(|e| panic!("{e}: {out}{err}"));

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
            "--sensor-noise-deg",
            "0",
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
            "--dwell-ms",
            "400",
            "--no-identify",
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
    let (sim_sets, sim_replans) = from_run(&sim);
    let (replay_sets, replay_replans) = from_replay_log(&replay_log);
    assert!(
        !sim_replans.is_empty(),
        "the plant is the model's: nothing to replan\n{sim}"
    );
    // Known to part (issue 30, open): with the same goal and a noiseless sensor the two loops
    // switch the same sets and replan after the same steps for the first steps (a replan after
    // every step), and part later, at a step that varies from run to run (5 and 7 seen): the
    // virtual ball is integrated in real time, so its readings differ from the simulation's by
    // about 1e-6 and from one rehearsal to the next, and a decision of the replan is still that
    // sensitive (with the fit of the wells on, the fit's refinement parts them at step 3). This
    // asserts the first three steps, the replans after each of them included.
    let agreed = 3;
    for (k, a) in sim_sets.iter().enumerate().take(agreed) {
        let b = replay_sets.get(k);
        assert_eq!(
            Some(a),
            b,
            "step {k}: the simulation switched {a:?}, the replay {b:?}\n{said}\n{sim}"
        );
    }
    let before = |v: &[usize]| {
        v.iter()
            .copied()
            .filter(|&k| k < agreed)
            .collect::<Vec<_>>()
    };
    assert_eq!(
        before(&sim_replans),
        before(&replay_replans),
        "{said}\n{sim}"
    );
    assert_eq!(
        before(&sim_replans),
        (0..agreed).collect::<Vec<_>>(),
        "{sim}"
    );
    // the simulated run as it ends: at the step limit, no fit
    assert_eq!(
        sim_code == 0,
        summary["reached"].as_bool().unwrap(),
        "{out}{err}"
    );
}
