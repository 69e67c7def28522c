//! Settles N deterministic 3-pair active sets of a scenario one after the other (one thread),
//! times them, and writes one CSV row per set: the Rust side of `benches/scipy_settle.py` and
//! `benches/numba_settle.py`.
//!
//! ```text
//! cargo run --release --example settle_sets -- [SCENARIO] [--sets N] [--planner [--seed S]] [--out FILE.csv]
//! ```
//!
//! The sets are built as in benches/settle.rs: from a fixed start orientation (0.08 rad about
//! (0.2, 1, 0.4) normalised), ordered triples of distinct coils (a, b, c) in lexicographic order,
//! each coil paired with the rotor magnet nearest to it at the start. With `--planner`, sets as
//! a planner meets them instead: each from its own random start (splitmix64, seed S,
//! default 32), three distinct coils each with a distinct magnet within [`PLANNER_REACH_DEG`] of
//! it there, drawn at random (`planner_sets`; benches/settle.rs benches the same sets, on the
//! physics of benches/planner-sets.toml). The whole loop over the sets is run once to record the
//! results, then repeated until at least 0.5 s of settling has been timed; each row's `mean_us`
//! is that set's mean time per settle over the timed passes. The summary line gives the mean,
//! median and 99th percentile of the evaluations and of the times.

mod basins_common;

use anyhow::{bail, Context, Result};
use nalgebra::Vector3;
use spherestep::io::scenario::Scenario;
use spherestep::model::geometry::{rot_q, unit, CoilId, Orientation, Pair, Radians};
use spherestep::physics::dynamics::{settle, SettleResult};
use spherestep::planning::commutation::nearest_magnet;
use std::fmt::Write as _;
use std::hint::black_box;
use std::path::PathBuf;
use std::time::{Duration, Instant};

const USAGE: &str =
    "usage: settle_sets [SCENARIO] [--sets N] [--planner [--seed S]] [--out FILE.csv]
  SCENARIO      scenario TOML (default scenarios/prototype.toml)
  --sets N      number of 3-pair active sets to settle (default 200)
  --planner     sets as a planner meets them: each from its own random start, three pairs
                whose magnets are within 24 degrees of their coils (see benches/planner-sets.toml)
  --seed S      the random sets' seed (default 32)
  --out FILE    write one CSV row per set to FILE (default: no CSV, only the summary line)";

/// How far (degrees) a `--planner` set's magnets may be from their coils at its start.
const PLANNER_REACH_DEG: f64 = 24.0;

/// Least total time of the timed passes.
const MIN_TIMED: Duration = Duration::from_millis(500);

struct Args {
    scenario: PathBuf,
    sets: usize,
    planner: bool,
    seed: u64,
    out: Option<PathBuf>,
}

fn parse_args() -> Result<Option<Args>> {
    let mut scenario: Option<PathBuf> = None;
    let mut sets = 200usize;
    let mut out = None;
    let (mut planner, mut seed) = (false, 32u64);
    let mut it = std::env::args_os().skip(1);
    while let Some(a) = it.next() {
        let Some(s) = a.to_str() else {
            bail!("argument {a:?} is not valid UTF-8\n{USAGE}");
        };
        match s {
            "-h" | "--help" => return Ok(None),
            "--sets" => {
                let v = it.next().with_context(|| {
                    format!("--sets needs a value: a whole number >= 1\n{USAGE}")
                })?;
                let v = v.to_string_lossy();
                sets = match v.trim().parse::<usize>() {
                    Ok(n) if n >= 1 => n,
                    _ => bail!("--sets expects a whole number >= 1, got '{v}'"),
                };
            }
            "--planner" => planner = true,
            "--seed" => {
                let v = it
                    .next()
                    .with_context(|| format!("--seed needs a whole number\n{USAGE}"))?;
                let v = v.to_string_lossy();
                seed = match v.trim().parse::<u64>() {
                    Ok(n) => n,
                    _ => bail!("--seed expects a whole number, got '{v}'"),
                };
            }
            "--out" => {
                let v = it
                    .next()
                    .with_context(|| format!("--out needs a file name\n{USAGE}"))?;
                out = Some(PathBuf::from(v));
            }
            _ if s.starts_with('-') => bail!("unknown option '{s}'\n{USAGE}"),
            _ => {
                if let Some(prev) = &scenario {
                    bail!(
                        "expected one scenario file, got '{}' and '{s}'\n{USAGE}",
                        prev.display()
                    );
                }
                scenario = Some(PathBuf::from(s));
            }
        }
    }
    Ok(Some(Args {
        scenario: scenario.unwrap_or_else(|| PathBuf::from("scenarios/prototype.toml")),
        sets,
        planner,
        seed,
        out,
    }))
}

/// The first `n` sets of benches/settle.rs: ordered triples of distinct coils.
fn build_sets(sc: &Scenario, q0: &Orientation, n: usize) -> Result<Vec<Vec<Pair>>> {
    let coils = sc.stator.points.len();
    if coils < 3 {
        bail!(
            "{}: 3-pair sets need at least 3 stator coils, the scenario has {coils}",
            sc.path.display()
        );
    }
    if sc.rotor.points.is_empty() {
        bail!("{}: the scenario has no rotor magnets", sc.path.display());
    }
    let available = coils * (coils - 1) * (coils - 2);
    if n > available {
        bail!("--sets expects at most {available} (ordered triples of {coils} coils), got {n}");
    }
    let mut near = Vec::with_capacity(coils);
    for c in 0..coils {
        let (magnet, _) = nearest_magnet(&sc.torques, CoilId(c), q0);
        near.push(Pair {
            coil: CoilId(c),
            magnet,
        });
    }
    let mut sets = Vec::with_capacity(n);
    'outer: for a in 0..coils {
        for b in 0..coils {
            for c in 0..coils {
                if a != b && b != c && a != c {
                    sets.push(vec![near[a], near[b], near[c]]);
                    if sets.len() == n {
                        break 'outer;
                    }
                }
            }
        }
    }
    Ok(sets)
}

fn set_label(set: &[Pair]) -> String {
    set.iter()
        .map(|p| p.to_string())
        .collect::<Vec<_>>()
        .join(";")
}

/// The sets to settle, each with its start: `build_sets`' from the fixed start, or with
/// `--planner` the planner-like sets of `basins_common::planner_sets`.
fn sets_of(sc: &Scenario, args: &Args) -> Result<Vec<(Orientation, Vec<Pair>)>> {
    if args.planner {
        let mut rng = basins_common::Rng::new(args.seed);
        return Ok(basins_common::planner_sets(
            &sc.torques,
            args.sets,
            PLANNER_REACH_DEG,
            &mut rng,
        ));
    }
    let axis = unit(Vector3::new(0.2, 1.0, 0.4)).context("start axis")?;
    let q0 = rot_q(&axis, Radians(0.08));
    Ok(build_sets(sc, &q0, args.sets)?
        .into_iter()
        .map(|s| (q0, s))
        .collect())
}

/// Each set's mean time per settle over passes of the whole loop repeated until [`MIN_TIMED`]
/// has been spent settling, and the mean over all.
fn time_sets(sc: &Scenario, sets: &[(Orientation, Vec<Pair>)]) -> (Vec<f64>, f64) {
    let mut per_set = vec![Duration::ZERO; sets.len()];
    let mut total = Duration::ZERO;
    let mut passes = 0u32;
    while total < MIN_TIMED {
        let pass = Instant::now();
        for (k, (q0, s)) in sets.iter().enumerate() {
            let t = Instant::now();
            black_box(settle(
                &sc.torques,
                black_box(s),
                black_box(q0),
                sc.body,
                sc.settle,
            ));
            per_set[k] += t.elapsed();
        }
        total += pass.elapsed();
        passes += 1;
    }
    let us = |d: Duration| d.as_secs_f64() * 1e6 / passes as f64;
    let mean = us(total) / sets.len() as f64;
    (per_set.into_iter().map(us).collect(), mean)
}

/// The mean, median and 99th percentile (nearest rank) of `v`.
fn spread(v: &[f64]) -> (f64, f64, f64) {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    let median = if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    };
    let p99 = s[((0.99 * n as f64).ceil() as usize).clamp(1, n) - 1];
    (s.iter().sum::<f64>() / n as f64, median, p99)
}

fn write_csv(
    out: &PathBuf,
    sets: &[(Orientation, Vec<Pair>)],
    results: &[SettleResult],
    per_set_us: &[f64],
) -> Result<()> {
    let mut csv = String::from(
        "set,qx0,qy0,qz0,qw0,qx,qy,qz,qw,settled,evaluations,steps,settle_time_s,mean_us\n",
    );
    for (((q0, set), r), us) in sets.iter().zip(results).zip(per_set_us) {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{:.4}",
            set_label(set),
            q0.i,
            q0.j,
            q0.k,
            q0.w,
            r.q.i,
            r.q.j,
            r.q.k,
            r.q.w,
            r.settled,
            r.evaluations,
            r.steps,
            r.settle_time_s,
            us,
        );
    }
    std::fs::write(out, csv).with_context(|| format!("writing {}", out.display()))
}

fn run() -> Result<()> {
    let Some(args) = parse_args()? else {
        println!("{USAGE}");
        return Ok(());
    };
    let sc = Scenario::load(&args.scenario)
        .with_context(|| format!("loading scenario {}", args.scenario.display()))?;
    let sets = sets_of(&sc, &args)?;
    for (k, (_, set)) in sets.iter().enumerate() {
        sc.check_active(set, &format!("set {k}"))?;
    }
    // First pass: the results (and a warm-up).
    let results: Vec<SettleResult> = sets
        .iter()
        .map(|(q0, s)| settle(&sc.torques, s, q0, sc.body, sc.settle))
        .collect();
    let (per_set_us, mean_us) = time_sets(&sc, &sets);
    if let Some(out) = &args.out {
        write_csv(out, &sets, &results, &per_set_us)?;
    }
    let n = sets.len();
    let evals: Vec<f64> = results.iter().map(|r| r.evaluations as f64).collect();
    let (e_mean, e_median, e_p99) = spread(&evals);
    let (_, us_median, us_p99) = spread(&per_set_us);
    let settled = results.iter().filter(|r| r.settled).count();
    println!(
        "rust: {n} settles, mean {mean_us:.2} us per settle, {e_mean:.1} evaluations per settle"
    );
    println!(
        "  evaluations mean / median / p99: {e_mean:.1} / {e_median:.0} / {e_p99:.0}; \
         us per settle mean / median / p99: {mean_us:.2} / {us_median:.2} / {us_p99:.2}; \
         {settled} of {n} settled"
    );
    Ok(())
}

fn main() {
    if let Err(e) = run() {
        eprintln!("settle_sets: error: {e:#}");
        std::process::exit(2);
    }
}
