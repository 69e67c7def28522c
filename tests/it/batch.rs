//! Batch runs: identical bytes for any --jobs, shards that merge into the full run, no
//! half-written files after a kill and --resume completing it, a broken scenario reported by
//! name while the good ones finish.

use crate::common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A folder of small scenarios: three plans and a 24-axis sweep over two schemes.
fn scenarios(dir: &Path) -> PathBuf {
    let s = dir.join("scen");
    std::fs::create_dir_all(&s).unwrap();
    for (name, axis) in [
        ("a-z", "[0, 0, 1]"),
        ("b-y", "[0, 1, 0]"),
        ("c-xy", "[1, 1, 0]"),
    ] {
        std::fs::write(
            s.join(format!("{name}.toml")),
            format!("[plan]\naxis = {axis}\nangle_deg = 60\n"),
        )
        .unwrap();
    }
    std::fs::write(
        s.join("d-sweep.toml"),
        "[plan]\nangle_deg = 45\n[sweep]\naxes = \"sphere\"\naxis_count = 24\nschemes = [\"weighted\", \"search\"]\n",
    )
    .unwrap();
    s
}

use common::batch;

/// Every file below `dir` (relative path -> bytes), timing.csv left out (wall time).
fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    for p in common::files_below(dir) {
        let rel = p.strip_prefix(dir).unwrap().to_string_lossy().into_owned();
        if rel != "timing.csv" {
            out.insert(rel, std::fs::read(&p).unwrap());
        }
    }
    out
}

#[test]
fn jobs_1_and_2_give_identical_bytes() {
    let t = tempfile::tempdir().unwrap();
    let s = scenarios(t.path());
    let (o1, o2) = (t.path().join("o1"), t.path().join("o2"));
    let r1 = batch(&[
        s.to_str().unwrap(),
        "--out",
        o1.to_str().unwrap(),
        "--jobs",
        "1",
    ]);
    let r2 = batch(&[
        s.to_str().unwrap(),
        "--out",
        o2.to_str().unwrap(),
        "--jobs",
        "2",
    ]);
    assert!(r1.status.success() && r2.status.success());
    let (f1, f2) = (files(&o1), files(&o2));
    assert_eq!(f1, f2);
    // four scenario CSVs with their hashes, and the summary
    assert_eq!(f1.len(), 9, "{:?}", f1.keys());
    let summary = String::from_utf8(f1["summary.csv"].clone()).unwrap();
    assert_eq!(summary.lines().count(), 5);
    assert!(summary.contains("\nd-sweep,sweep,48,24 axes,45,weighted;search,dynamic,2-4,"));
    let sweep = String::from_utf8(f1["d-sweep.csv"].clone()).unwrap();
    assert_eq!(sweep.lines().count(), 49);
    assert!(o1.join("timing.csv").is_file());
}

#[test]
fn shards_merge_into_the_full_run() {
    let t = tempfile::tempdir().unwrap();
    let s = scenarios(t.path());
    let full = t.path().join("full");
    let parts = t.path().join("parts");
    assert!(
        batch(&[s.to_str().unwrap(), "--out", full.to_str().unwrap()])
            .status
            .success()
    );
    for i in 0..3 {
        let sh = format!("{i}/3");
        let r = batch(&[
            s.to_str().unwrap(),
            "--out",
            parts.to_str().unwrap(),
            "--shard",
            &sh,
        ]);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    }
    // the shards are disjoint: each plan once, the sweep in three parts
    let before = files(&parts);
    assert!(!before.contains_key("summary.csv"));
    assert!(before.contains_key("d-sweep.shard-0-of-3.csv"));
    assert!(!before.contains_key("d-sweep.csv"));
    let rows: usize = (0..3)
        .map(|i| {
            String::from_utf8(before[&format!("d-sweep.shard-{i}-of-3.csv")].clone())
                .unwrap()
                .lines()
                .count()
                - 1
        })
        .sum();
    assert_eq!(rows, 48);
    // merging: a plain run with --resume over the same folder
    let r = batch(&[
        s.to_str().unwrap(),
        "--out",
        parts.to_str().unwrap(),
        "--resume",
    ]);
    assert!(r.status.success());
    assert!(String::from_utf8_lossy(&r.stdout).starts_with("0 computed, 4 up to date"));
    let merged: BTreeMap<String, Vec<u8>> = files(&parts)
        .into_iter()
        .filter(|(k, _)| !k.contains(".shard-"))
        .collect();
    assert_eq!(merged, files(&full));
}

#[test]
fn a_killed_run_leaves_no_half_written_csv_and_resume_completes_it() {
    let t = tempfile::tempdir().unwrap();
    let s = scenarios(t.path());
    // a heavier sweep (seconds), so that the kill lands while it runs
    std::fs::write(
        s.join("e-big.toml"),
        "[plan]\nangle_deg = 90\nmodel = \"dynamic\"\n[sweep]\naxes = \"sphere\"\naxis_count = 300\nschemes = [\"weighted\"]\n",
    )
    .unwrap();
    let out = t.path().join("out");
    let mut child = Command::new(common::bin())
        .args([
            "batch",
            s.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--jobs",
            "1",
        ])
        .spawn()
        .unwrap();
    // kill it as soon as the first scenario's file is there
    let start = std::time::Instant::now();
    while !out.join("a-z.csv").exists() && start.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(out.join("a-z.csv").exists());
    // whatever is there is whole: every CSV parses with the right column count
    for (name, bytes) in files(&out) {
        if name.ends_with(".csv") {
            let mut rdr = csv::Reader::from_reader(bytes.as_slice());
            let width = rdr.headers().unwrap().len();
            for r in rdr.records() {
                assert_eq!(r.unwrap().len(), width, "{name}");
            }
        }
    }
    assert!(
        !out.join("e-big.csv").exists(),
        "the big sweep cannot have finished"
    );
    // resume: the rest is computed, nothing finished is redone, and it equals a fresh run
    let r = batch(&[
        s.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--resume",
    ]);
    assert!(r.status.success());
    assert!(out.join("e-big.csv").is_file());
    let fresh = t.path().join("fresh");
    assert!(
        batch(&[s.to_str().unwrap(), "--out", fresh.to_str().unwrap()])
            .status
            .success()
    );
    let resumed: BTreeMap<_, _> = files(&out)
        .into_iter()
        .filter(|(k, _)| !k.ends_with(".tmp"))
        .collect();
    assert_eq!(resumed, files(&fresh));
    // a second resume computes nothing
    let r = batch(&[
        s.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--resume",
    ]);
    assert!(String::from_utf8_lossy(&r.stdout).starts_with("0 computed, 5 up to date"));
}

#[test]
fn a_broken_scenario_is_reported_by_name_and_the_rest_finish() {
    let t = tempfile::tempdir().unwrap();
    let s = scenarios(t.path());
    std::fs::write(s.join("broken.toml"), "[plan]\naxis = [0, 0, 0]\n").unwrap();
    let out = t.path().join("out");
    let r = batch(&[s.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(r.status.code(), Some(1));
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        err.contains("broken.toml") && err.contains("plan.axis"),
        "{err}"
    );
    for n in ["a-z", "b-y", "c-xy", "d-sweep"] {
        assert!(out.join(format!("{n}.csv")).is_file(), "{n} must finish");
    }
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    assert_eq!(summary.lines().count(), 5);
}

#[test]
fn bad_shard_and_jobs_arguments_are_refused() {
    let t = tempfile::tempdir().unwrap();
    let s = scenarios(t.path());
    let out = t.path().join("out");
    for bad in ["3/3", "1-3", "x/2", "0/0"] {
        let r = batch(&[
            s.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--shard",
            bad,
        ]);
        assert_eq!(r.status.code(), Some(1));
        assert!(String::from_utf8_lossy(&r.stderr).contains("--shard"));
    }
    let r = batch(&[
        s.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--jobs",
        "0",
    ]);
    assert_eq!(r.status.code(), Some(1));
    // More threads than any machine runs are refused at once (they were
    // all started before any work)
    for jobs in ["257", "100000", "0"] {
        let r = batch(&[
            s.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--jobs",
            jobs,
        ]);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(1), "{jobs}: {err}");
        assert!(
            err.contains(&format!(
                "argument --jobs: expected a number of worker threads from 1 to 256, got {jobs}"
            )),
            "{err}"
        );
    }
}

#[test]
fn a_random_motion_sweep_plans_each_motion_from_its_own_start_and_reports_where_it_ends() {
    use spherestep::io::scenario::{random_motions, Scenario};
    use spherestep::model::geometry::Radians;
    use spherestep::planning::plan::{final_orientation_error_deg, max_path_deviation_deg};
    use spherestep::planning::planner::{plan, PlanSettings};
    let dir = tempfile::tempdir().unwrap();
    let s = dir.path().join("scen");
    std::fs::create_dir_all(&s).unwrap();
    let text = "[sweep]\nmotions = 3\nseed = 4\nangle_min_deg = 20\nangle_max_deg = 120\n";
    std::fs::write(s.join("m.toml"), text).unwrap();
    let out = dir.path().join("out");
    let r = batch(&[
        s.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--jobs",
        "2",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let csv = std::fs::read_to_string(out.join("m.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let sc = Scenario::load(&s.join("m.toml")).unwrap();
    let (lo, hi) = (Radians(20f64.to_radians()), Radians(120f64.to_radians()));
    let motions = random_motions(3, 4, lo, hi);
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 3);
    for (m, row) in motions.iter().zip(&rows) {
        let deg = m.angle.0.to_degrees();
        assert!((20.0..=120.0).contains(&deg));
        assert_eq!(row[col("angle_deg")], deg.to_string());
        assert_eq!(row[col("axis_x")], m.axis.x.to_string());
        assert_eq!(row[col("start_qw")], m.start.w.to_string());
        assert_eq!(row[col("start_qx")], m.start.i.to_string());
        // the row's final orientation error is that of the plan from the motion's start
        let settings = PlanSettings {
            axis: m.axis,
            angle: m.angle,
            start: m.start,
            ..sc.plan.clone()
        };
        let p = plan(&sc.motor(), &settings);
        let e = final_orientation_error_deg(&settings, &p.rows);
        assert_eq!(row[col("final_orientation_error_deg")], e.to_string());
        // and its path deviation, beside its worst axis error
        let d = max_path_deviation_deg(&settings, &p.rows);
        assert_eq!(row[col("max_path_deviation_deg")], d.to_string());
        assert!(d > 0.0 && d < 30.0, "{d}");
    }
    assert_eq!(col("max_path_deviation_deg"), col("max_axis_error_deg") + 1);
    // summary.csv has the sweep's worst path deviation
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let mut lines = summary.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let at = head
        .iter()
        .position(|h| *h == "max_path_deviation_deg")
        .unwrap();
    let worst = rows
        .iter()
        .map(|r| r[col("max_path_deviation_deg")].parse::<f64>().unwrap())
        .fold(0.0, f64::max);
    let m_row: Vec<&str> = lines
        .find(|l| l.starts_with("m,"))
        .unwrap()
        .split(',')
        .collect();
    assert_eq!(m_row[at], worst.to_string());
    // the starts differ: each motion has its own
    assert_ne!(rows[0][col("start_qw")], rows[1][col("start_qw")]);
    // motions beside axes or angles are refused, naming the field
    for (extra, field) in [
        ("axis_count = 4\n", "sweep.axis_count"),
        ("angles_deg = [30]\n", "sweep.angles_deg"),
    ] {
        std::fs::write(s.join("m.toml"), format!("{text}{extra}")).unwrap();
        let e = Scenario::load(&s.join("m.toml")).unwrap_err().to_string();
        assert!(e.contains(field), "{e}");
    }
    std::fs::write(s.join("m.toml"), "[sweep]\nseed = 3\n").unwrap();
    let e = Scenario::load(&s.join("m.toml")).unwrap_err().to_string();
    assert!(e.contains("sweep.seed") && e.contains("motions"), "{e}");
}

#[test]
fn the_summary_says_reached_as_plan_does_at_the_target_orientation() {
    // the same 30 degree plan judged with a tolerance it cannot meet and with one it meets:
    // summary.csv's `reached` is what `plan` says (it counted the angle alone before)
    let t = tempfile::tempdir().unwrap();
    let dir = t.path().join("sc");
    std::fs::create_dir(&dir).unwrap();
    for (name, tol) in [("tight", 0.001), ("loose", 10.0)] {
        std::fs::write(
            dir.join(format!("{name}.toml")),
            format!(
                "name = \"{name}\"\n[plan]\naxis = [0, 0, 1]\nangle_deg = 30.0\n\
                 tolerance_deg = {tol}\n"
            ),
        )
        .unwrap();
    }
    let out = t.path().join("out");
    let r = batch(&[dir.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let reached = |name: &str| {
        let line = summary
            .lines()
            .find(|l| l.starts_with(&format!("{name},plan,")))
            .unwrap_or_else(|| panic!("{summary}"));
        line.split(',').nth(12).unwrap().to_string()
    };
    let header: Vec<&str> = summary.lines().next().unwrap().split(',').collect();
    assert_eq!(header[12], "reached");
    assert_eq!(reached("tight"), "false", "{summary}");
    assert_eq!(reached("loose"), "true", "{summary}");
}
