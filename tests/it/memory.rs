//! Memory grows no faster than the problem needs: a pivot plan on a rotor
//! of 5,000 magnets. Its search used to expand every initial state at once (some 1,300 here,
//! about 700 MB of partial plans; 11.6 GB with 20,000 magnets); expanded in chunks it stays
//! under 50 MB. The packing report of a rotor of 12,000 magnets counts its pairwise distances
//! in bins instead of keeping them (576 MB before). The peak is read from the running process
//! (Linux: `VmHWM` in /proc). A path through 1,000 waypoints keeps no copy of the plan per
//! waypoint (61 MB before, growing with the square of the count).

use crate::common;

use std::io::Write;
use std::process::{Command, Stdio};
use std::time::Duration;

/// A rotor of `n` magnets spread evenly over the sphere (a Fibonacci lattice), as a points CSV.
fn fibonacci_rotor(n: usize) -> String {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let mut s = String::from("x,y,z\n");
    for i in 0..n {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let r = (1.0 - z * z).sqrt();
        let t = golden * i as f64;
        s.push_str(&format!(
            "{:.12},{:.12},{z:.12}\n",
            r * t.cos(),
            r * t.sin()
        ));
    }
    s
}

/// The peak resident memory of process `pid` so far, kB (None once it has exited).
fn peak_kb(pid: u32) -> Option<u64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// Writes a scenario whose rotor is `n` magnets of [`fibonacci_rotor`] into `dir`.
fn big_scenario(dir: &std::path::Path, n: usize) -> std::path::PathBuf {
    std::fs::write(dir.join("rotor.csv"), fibonacci_rotor(n)).unwrap();
    let scenario = dir.join("big.toml");
    let mut f = std::fs::File::create(&scenario).unwrap();
    writeln!(f, "name = \"big\"\n[rotor]\nfile = \"rotor.csv\"").unwrap();
    scenario
}

/// Runs the binary with `args` to its end: its peak resident memory, kB.
fn peak_of(args: &[&str]) -> u64 {
    let mut child = Command::new(common::bin())
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut peak = 0;
    let status = loop {
        if let Some(kb) = peak_kb(child.id()) {
            peak = peak.max(kb);
        }
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(status.success(), "{status}");
    assert!(peak > 0, "the peak memory was never read");
    peak
}

#[cfg(target_os = "linux")]
#[test]
fn a_pivot_plan_on_a_rotor_of_5000_magnets_stays_small() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = big_scenario(dir.path(), 5000);
    let s = scenario.to_string_lossy();
    let peak = peak_of(&["plan", &s, "--model", "pivot", "--angle", "90", "--json"]);
    assert!(peak < 200_000, "peak resident memory {peak} kB");
}

#[cfg(target_os = "linux")]
#[test]
fn the_packing_report_of_a_rotor_of_12000_magnets_stays_small() {
    // 72 million magnet pairs: kept and sorted they took 576 MB (2.35 GB with 20,000
    // magnets); counted in bins of the merge tolerance they take a few
    let dir = tempfile::tempdir().unwrap();
    let scenario = big_scenario(dir.path(), 12_000);
    let peak = peak_of(&["packing", &scenario.to_string_lossy()]);
    assert!(peak < 60_000, "peak resident memory {peak} kB");
}

#[cfg(target_os = "linux")]
#[test]
fn a_path_through_1000_waypoints_stays_small() {
    // every waypoint served kept a copy of the whole plan so far (and of every waypoint) to go
    // back to, and every leg tried another: memory grew with the square of the waypoints (61
    // MB here, 5.4 GB and growing for 10,000); now the plan's length and the leg's own rows
    let dir = tempfile::tempdir().unwrap();
    let mut turns = String::from("axis_x,axis_y,axis_z,angle_deg\n");
    for k in 0..1000 {
        turns.push_str(["1,0,0,2\n", "0,1,0,2\n", "-1,0,0,2\n", "0,-1,0,2\n"][k % 4]);
    }
    let file = dir.path().join("turns.csv");
    std::fs::write(&file, turns).unwrap();
    let out = dir.path().join("plan.csv");
    let peak = peak_of(&[
        "plan",
        "scenarios/prototype.toml",
        "--waypoints",
        &file.to_string_lossy(),
        "--out",
        &out.to_string_lossy(),
    ]);
    assert!(peak < 25_000, "peak resident memory {peak} kB");
}
