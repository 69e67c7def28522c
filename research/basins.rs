//! Does the default settle land where the reference does? Settles random active sets of issue
//! 17's setup (80-magnet rotor, 16-coil stator, wells of 25 degrees reach, omega_tol 1e-4,
//! torque_tol 1e-6, t_max 30 s; all sets from one random start) with the default stepper and
//! with the reference (ode_solvers' Dopri5 at rtol 1e-10, atol 1e-12), and counts per kind the
//! sets that land in another equilibrium (both settled, more than 1e-3 rad apart) and the sets
//! outside the agreement bounds (1e-4 rad, settle time within 2% + 0.05 s, same settled flag).
//!
//! ```text
//! cargo run --release --example basins -- [--sets N] [--seed S] [--kind K] [--coils]
//! ```
//!
//! Kinds: gaussian and cosine wells, each with light (0.2), medium (0.7) and heavy (2.0)
//! damping (fraction of critical for one aligned pair), pairs 2, 3, 4, 5 in turn; plus the
//! the first kind checked, gaussian, 0.7, 3 pairs. `--kind K` runs only kind K (0-based, as listed).
//! `--coils`: the same sets in the "coils" interaction (each set's coils energised, every magnet
//! within reach of one pulls), where a settle costs about 20 times more.

mod basins_common;

use anyhow::{bail, Context, Result};
use basins_common::{compare, random_sets, setup, Kind, Rng, Shape};
use rayon::prelude::*;
use spherestep::physics::dynamics::settle;
use spherestep::physics::torque::Interaction;
use std::time::Instant;

fn kinds() -> Vec<(Kind, bool)> {
    let mut out = vec![(
        Kind {
            shape: Shape::Gaussian,
            damping_ratio: 0.7,
            pairs: 3,
        },
        false,
    )];
    for shape in [Shape::Gaussian, Shape::Cosine] {
        for damping_ratio in [0.2, 0.7, 2.0] {
            out.push((
                Kind {
                    shape,
                    damping_ratio,
                    pairs: 0,
                },
                true,
            ));
        }
    }
    out
}

fn arg_value<T: std::str::FromStr>(args: &[String], name: &str) -> Result<Option<T>> {
    match args.iter().position(|a| a == name) {
        None => Ok(None),
        Some(i) => {
            let v = args
                .get(i + 1)
                .with_context(|| format!("{name} needs a value"))?;
            match v.parse() {
                Ok(x) => Ok(Some(x)),
                Err(_) => bail!("{name}: cannot read '{v}'"),
            }
        }
    }
}

fn run() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: usize = arg_value(&args, "--sets")?.unwrap_or(4000);
    let seed: u64 = arg_value(&args, "--seed")?.unwrap_or(17);
    let only: Option<usize> = arg_value(&args, "--kind")?;
    let coils = args.iter().any(|a| a == "--coils");
    println!(
        "kind | shape | damping | pairs | sets | settled (ref) | other basin | outside bounds | flag differs | \
         worst angle rad | worst dt s | evals fast / ref | ms fast / ref"
    );
    let (mut total_other, mut total_outside) = (0, 0);
    for (k, (kind, mixed)) in kinds().into_iter().enumerate() {
        if only.is_some_and(|o| o != k) {
            continue;
        }
        let (mut torques, body, params) = setup(kind.shape, kind.damping_ratio);
        if coils {
            torques.interaction = Interaction::Coils;
        }
        let mut rng = Rng::new(seed.wrapping_add(k as u64));
        let q0 = rng.orientation();
        let sets: Vec<_> = if mixed {
            let per = n / 4;
            let mut v = Vec::new();
            for p in 2..=5 {
                let count = if p == 5 { n - 3 * per } else { per };
                v.extend(random_sets(&torques, &q0, p, count, &mut rng));
            }
            v
        } else {
            random_sets(&torques, &q0, kind.pairs, n, &mut rng)
        };
        let t = Instant::now();
        let fast: Vec<_> = sets
            .par_iter()
            .map(|s| settle(&torques, s, &q0, body, params))
            .collect();
        let t_fast = t.elapsed();
        let t = Instant::now();
        let reference: Vec<_> = sets
            .par_iter()
            .map(|s| settle(&torques, s, &q0, body, params.reference()))
            .collect();
        let t_ref = t.elapsed();
        let (mut other, mut outside, mut settled, mut flag) = (0, 0, 0, 0);
        let (mut worst_angle, mut worst_dt) = (0.0f64, 0.0f64);
        for ((set, f), r) in sets.iter().zip(&fast).zip(&reference) {
            let c = compare(f, r);
            settled += r.settled as usize;
            other += c.other_basin as usize;
            flag += (!c.same_flag) as usize;
            if !c.agrees {
                outside += 1;
                if outside <= 3 || c.other_basin || !c.same_flag {
                    eprintln!(
                        "  kind {k}: {set:?}: {:.3e} rad, t {:.4} / {:.4} s, settled {} / {}",
                        c.angle, f.settle_time_s, r.settle_time_s, f.settled, r.settled
                    );
                }
            }
            if f.settled && r.settled {
                worst_angle = worst_angle.max(c.angle);
                worst_dt = worst_dt.max(c.dt);
            }
        }
        let mean = |v: &[spherestep::physics::dynamics::SettleResult]| {
            v.iter().map(|r| r.evaluations as f64).sum::<f64>() / v.len() as f64
        };
        println!(
            "{k} | {:?} | {} | {} | {} | {settled} | {other} | {outside} | {flag} | {worst_angle:.2e} | \
             {worst_dt:.2e} | {:.0} / {:.0} | {:.0} / {:.0}",
            kind.shape,
            kind.damping_ratio,
            if mixed {
                "2-5".to_string()
            } else {
                kind.pairs.to_string()
            },
            sets.len(),
            mean(&fast),
            mean(&reference),
            t_fast.as_secs_f64() * 1e3,
            t_ref.as_secs_f64() * 1e3,
        );
        total_other += other;
        total_outside += outside;
    }
    println!(
        "total: {total_other} sets in another equilibrium, {total_outside} outside the bounds"
    );
    Ok(())
}

fn main() {
    if let Err(e) = run() {
        eprintln!("basins: error: {e:#}");
        std::process::exit(2);
    }
}
