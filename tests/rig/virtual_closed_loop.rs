//! `replay --sensor` through the virtual motor against the simulated closed loop with the same
//! plant and seed, the same plan file and so the same goal: the same coils on at every step,
//! the same replans, the same ending (both at the goal, or both stopped at the step limit) and
//! the same last distance from the goal, without the fit of the wells and with it. The
//! simulated loop is `simulate PLAN --plant PLANT --closed-loop`: a plan file does not say
//! where `plan` was asked to go (90 degrees about Z here; the plan's last row is 91.65
//! degrees), so `replay --sensor` and `simulate` of the same file both aim at its last row,
//! where `run` aims at the asked target and parts from them once it replans towards it.
//!
//! The plant is `cosine-35-coils` (cosine wells reaching 35 degrees, every coil pulling every
//! magnet in reach, half the stiffness; the model pairs each coil with one magnet in gaussian
//! wells), so the loop replans after every step without the fit, and the fit takes over after
//! step 1 with it. Every step settles in that plant, and the dwell on the virtual clock is
//! longer than every settle of the simulated run (checked): the virtual ball then rests at the
//! equilibrium of the very settle the simulated plant makes (`rehearse::plant`), and its
//! readings are the simulation's to the bit (a quat-csv line in full, no tare offset, no
//! mounting). The sensor is noiseless in both (the virtual sensor draws its noise per line it
//! prints, the simulated one per step: with noise their readings would be other samples).
//!
//! What the simulation does not have: the relays of a transition are switched one frame at a
//! time, and the ball moves under the sets in between for the frames' wall time times the
//! speed of the virtual clock. The virtual clock runs at the wall clock's speed: a frame's
//! round trip (well under a millisecond, a few on a loaded machine) is then a few milliseconds
//! on it. The most sensitive transition of these runs (step 6 without the fit) lands the ball
//! in another equilibrium from about 10 ms a frame, and the runs then part from there: at 20
//! times the wall clock a scheduling hiccup of half a millisecond did it, and at twice the wall
//! clock a machine loaded by three builds once did (frames of 5 ms). The on-time limit
//! is lifted (the replans' wall time counts while the coils are on, and the limit is not what
//! this test is about). Nothing asserts how fast anything ran. The two tests take turns (one
//! virtual motor at a time), so that neither slows the other's frames.
#![cfg(unix)]

use crate::common;

use spherestep::model::geometry::Orientation;
use std::collections::BTreeSet;
use std::path::Path;
use std::sync::Mutex;
use std::time::{Duration, Instant};

const GUARD: Duration = Duration::from_secs(300);

/// The virtual clock's speed, times the wall clock.
const SPEED: f64 = 1.0;

/// One rehearsal at a time.
static TURNS: Mutex<()> = Mutex::new(());

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

/// A quaternion from its w, x, y, z as a CSV has them (full precision), as the sensor's
/// parser takes it.
fn quaternion(w: &str, x: &str, y: &str, z: &str) -> Orientation {
    let c = [w, x, y, z].map(|t| t.parse::<f64>().unwrap());
    spherestep::sensor::unit_quaternion(c[0], c[1], c[2], c[3]).unwrap()
}

/// What one loop did: the coils on at each step, the steps replanned after, the measurement
/// after each step.
struct Loop {
    sets: Vec<BTreeSet<usize>>,
    replans: Vec<usize>,
    measured: Vec<Orientation>,
}

/// The loop of `simulate`'s CSV, and each step's settle time (s) and whether it settled.
fn from_run(csv: &str) -> (Loop, Vec<(f64, bool)>) {
    let mut lines = csv.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| head.iter().position(|h| *h == n).unwrap();
    let (a, r, s) = (col("active"), col("replanned"), col("step"));
    let m = ["measured_qw", "measured_qx", "measured_qy", "measured_qz"].map(col);
    let (t, settled) = (col("settle_time_s"), col("settled"));
    let mut l = Loop {
        sets: Vec::new(),
        replans: Vec::new(),
        measured: Vec::new(),
    };
    let mut settles = Vec::new();
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        let set = f[a]
            .split(';')
            .filter(|p| !p.is_empty())
            .map(|p| p.split(':').next().unwrap().parse().unwrap())
            .collect();
        l.sets.push(set);
        if f[r] == "true" {
            l.replans.push(f[s].parse().unwrap());
        }
        l.measured
            .push(quaternion(f[m[0]], f[m[1]], f[m[2]], f[m[3]]));
        settles.push((f[t].parse().unwrap(), f[settled] == "true"));
    }
    (l, settles)
}

/// The same from the replay's closed-loop log (`t_s,step,action,coil,channel,bytes,qw,qx,qy,
/// qz,...`).
fn from_replay_log(csv: &str) -> Loop {
    let mut on: BTreeSet<usize> = BTreeSet::new();
    let mut l = Loop {
        sets: Vec::new(),
        replans: Vec::new(),
        measured: Vec::new(),
    };
    for line in csv.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let (step, action) = (f[1], f[2]);
        match action {
            "on" => {
                on.insert(f[3].parse().unwrap());
            }
            "off" => {
                on.remove(&f[3].parse::<usize>().unwrap());
            }
            "sensor" => l.measured.push(quaternion(f[6], f[7], f[8], f[9])),
            "done" => {
                let k: usize = step.parse().unwrap();
                if l.sets.len() == k {
                    l.sets.push(on.clone());
                }
            }
            "replan" => l.replans.push(step.parse().unwrap()),
            _ => {}
        }
    }
    l
}

/// The simulated loop and the replay through the virtual motor of the same plan on the same
/// plant, with the fit of the wells or without (`identify`), the replay dwelling `dwell_ms` a
/// step (wall clock).
fn rehearse_and_compare(identify: bool, dwell_ms: u64) {
    let _turn = TURNS.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let model = write(
        d,
        "model.toml",
        "name = \"model\"\n[relay]\nboard = \"numato\"\ndwell_factor = 0.3\ndwell_floor_ms = 40\nmax_on_time_s = 1000\n",
    );
    // cosine wells reaching 35 degrees, every coil pulling: every step settles in it
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
    let fit: &[&str] = if identify { &[] } else { &["--no-identify"] };
    // the simulated loop on the plan file, as the replay plays it
    let sim_csv = d.join("simulated.csv").display().to_string();
    let sim_args = [
        "simulate",
        &plan,
        &model,
        "--plant",
        &plant,
        "--closed-loop",
        "--sensor-noise-deg",
        "0",
        "--seed",
        "7",
        "--json",
        "--out",
        &sim_csv,
    ];
    let (sim_code, out, err) = common::run(&[&sim_args[..], fit].concat());
    let sim = std::fs::read_to_string(&sim_csv).unwrap_or_else(|_| panic!("{out}{err}"));
    let summary: serde_json::Value =
        serde_json::from_str(out.trim()).unwrap_or_else(|e| panic!("{e}: {out}{err}"));
    let (sim_loop, settles) = from_run(&sim);
    // the ball at rest when it is measured: every settle within the dwell on the virtual
    // clock, with room for the virtual ball to come to rest by the settle's test too
    let dwell = dwell_ms as f64 / 1e3 * SPEED;
    let longest = settles.iter().map(|s| s.0).fold(0.0, f64::max);
    assert!(
        settles.iter().all(|s| s.1) && longest + 0.5 < dwell,
        "a step of the simulated run settles in {longest} s or not at all: the replay's dwell \
         ({dwell} s on the virtual clock) must be longer\n{sim}"
    );

    let links = d.join("dev");
    let speed = SPEED.to_string();
    let deadline = Instant::now() + GUARD;
    let mut v = common::start_virtual(&plant, &plan, &links, (&speed, "0"), deadline);
    let log = d.join("replay.csv").display().to_string();
    let dwell_s = dwell_ms.to_string();
    let (status, stdout, stderr) = common::replay_beside(
        &mut v,
        (&plan, &model),
        &links,
        (&log, &dwell_s),
        fit,
        deadline,
    );
    let said = format!("{status}\n{stdout}\n{stderr}");
    let vend = Instant::now() + Duration::from_secs(30);
    while v.try_wait().unwrap().is_none() {
        if Instant::now() > vend {
            let _ = v.kill();
            break;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let replay_log = std::fs::read_to_string(&log).unwrap_or_default();
    let replay = from_replay_log(&replay_log);
    let which = if identify {
        "with the fit"
    } else {
        "without the fit"
    };
    // each step's measurements side by side, for the messages
    let table: String = (0..sim_loop.measured.len().max(replay.measured.len()))
        .map(|k| {
            let (a, b) = (sim_loop.measured.get(k), replay.measured.get(k));
            let apart = match (a, b) {
                (Some(a), Some(b)) => format!("{:e} deg", a.angle_to(b).to_degrees()),
                _ => "-".into(),
            };
            format!(
                "step {k}: simulated {:?}, replayed {:?}; readings apart {apart}\n",
                sim_loop.sets.get(k),
                replay.sets.get(k)
            )
        })
        .collect();
    let context = format!("{which}\n{table}{said}");
    assert!(
        !sim_loop.replans.is_empty(),
        "the plant is the model's: nothing to replan\n{sim}"
    );
    // the same coils on at every step of the run, and no step more or less
    assert_eq!(sim_loop.sets, replay.sets, "{context}");
    assert_eq!(sim_loop.replans, replay.replans, "{context}");
    assert_eq!(
        summary["replans"].as_u64(),
        Some(replay.replans.len() as u64),
        "{context}"
    );
    // the same ending: both at the goal, or both stopped at the step limit
    let reached = summary["reached"].as_bool().unwrap();
    assert_eq!(sim_code == 0, reached, "{out}{err}");
    assert_eq!(status.success(), reached, "{context}");
    if reached {
        assert!(
            stdout.contains("closed loop done: at the goal"),
            "{context}"
        );
    } else {
        assert!(stderr.contains("without reaching the goal"), "{context}");
    }
    // the same last distance from the goal (the plan's last row), by the last readings
    let rows = spherestep::io::planfile::read_plan(Path::new(&plan)).unwrap();
    let goal = rows.last().unwrap().q;
    let (a, b) = (
        sim_loop.measured.last().unwrap(),
        replay.measured.last().unwrap(),
    );
    let (da, db) = (
        a.angle_to(&goal).to_degrees(),
        b.angle_to(&goal).to_degrees(),
    );
    assert!(
        (da - db).abs() < 1e-6,
        "the last readings are {da} and {db} deg from the goal\n{context}"
    );
    let last = summary["final_error_deg"].as_f64().unwrap();
    assert!((last - da).abs() < 1e-6, "{last} vs {da}\n{context}");
}

#[test]
fn replay_through_the_virtual_motor_decides_as_the_simulated_loop() {
    let _one = crate::one_at_a_time();
    // the settles of this run are at most 1.6 s: 2.2 s on the virtual clock
    rehearse_and_compare(false, 2200);
}

#[test]
fn replay_through_the_virtual_motor_decides_as_the_simulated_loop_with_the_fit_of_the_wells() {
    let _one = crate::one_at_a_time();
    // the fitted wells steer the ball into slower settles (up to 4.5 s): 5.1 s on the virtual
    // clock
    rehearse_and_compare(true, 5100);
}
