//! Memory grows no faster than the problem needs (issue 14, item 11): a pivot plan on a rotor
//! of 5,000 magnets. Its search used to expand every initial state at once (some 1,300 here,
//! about 700 MB of partial plans; 11.6 GB with 20,000 magnets); expanded in chunks it stays
//! under 50 MB. The peak is read from the running process (Linux: `VmHWM` in /proc).

mod common;

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

#[cfg(target_os = "linux")]
#[test]
fn a_pivot_plan_on_a_rotor_of_5000_magnets_stays_small() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("rotor.csv"), fibonacci_rotor(5000)).unwrap();
    let scenario = dir.path().join("big.toml");
    let mut f = std::fs::File::create(&scenario).unwrap();
    writeln!(f, "name = \"big\"\n[rotor]\nfile = \"rotor.csv\"").unwrap();
    let mut child = Command::new(common::bin())
        .args(["plan", &scenario.to_string_lossy(), "--model", "pivot"])
        .args(["--angle", "90", "--json"])
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
    assert!(peak < 200_000, "peak resident memory {peak} kB");
}
