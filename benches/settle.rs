//! Criterion benchmarks of the settle engine and the planner on the built-in prototype.
//!
//! - `settle/pairs/K`: one settle of a K-pair set (K = 2, 3, 4), the default fast path;
//!   `settle_dopri5/pairs/3`: the same 3-pair settle through ode_solvers' Dopri5 at the old
//!   default tolerances (rtol 1e-6, atol 1e-8), the engine before the speed work;
//! - `rhs/pairs/3`: one right-hand-side evaluation (a settle costs evaluations x this);
//! - `growth_pairs/K`: settle time against the number of pairs, K = 2 to 8;
//! - `growth_magnets_coils/N`: settle time of 2 energised coils in "coils" interaction against
//!   the number N of rotor magnets (evenly spread: `scenario::sphere_axes`), and `rhs_coils/N`;
//! - `settle_many/threads/T`: 1,000 3-pair sets on a rayon pool of T = 1 and 2 threads;
//! - `settle_planner/sets/4000`: the 4,000 planner-like sets (`research/settle_sets.rs
//!   --planner`, seed 32: each from its own random start, three pairs within 24 degrees of their
//!   coils) on `benches/planner-sets.toml`, one after the other on one thread (per set: the
//!   time over 4,000);
//! - `plan_y_dynamic3/angle/A`: the search planner, dynamic model, 3 pairs per step, about Y,
//!   against the target angle A in degrees;
//! - `dipole/rhs/W` and `dipole/settle/W`: physical magnets, real parts
//!   (`scenarios/prototype-physical.toml`, W = real: the disc and the winding, through their
//!   table) and a point dipole passing a thin loop (`tests/data/prototype-physical-point.toml`,
//!   W = dipole), against the prototype's gaussian wells with the same "coils" interaction
//!   (W = gaussian): one evaluation with 3 coils on over the 80 magnets, and one settle of a
//!   2-coil set (each coil's nearest magnet at the start);
//! - `coil_sets/soft-wells/56`: the 56 sets of three of the first eight coils (each with its
//!   nearest magnet at the start) on `scenarios/soft-wells.toml` ("coils" interaction, gaussian
//!   wells reaching 30 degrees, t_max 60 s), settled one after the other on one thread (per
//!   set: the time over 56): the settles a coil-set plan weighs.
//!
//! Run: `cargo bench --bench settle` (a group: `cargo bench --bench settle -- growth_pairs`).

#[path = "../research/basins_common.rs"]
mod basins_common;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use nalgebra::Vector3;
use spherestep::io::scenario::{sphere_axes, Scenario};
use spherestep::model::geometry::{rot_q, unit, CoilId, Degrees, Orientation, Pair, Radians};
use spherestep::physics::dynamics::{settle, settle_many, Method, RotorDynamics, SettleParams};
use spherestep::physics::integrator::OdeSystem;
use spherestep::physics::torque::{Interaction, MagnetTorques, TorqueModel};
use spherestep::planning::commutation::nearest_magnet;
use spherestep::planning::planner::plan;
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

fn load(name: &str) -> Scenario {
    Scenario::load(Path::new(name)).expect("the repository's scenarios load")
}

/// Coil `coil` paired with the magnet nearest to it at `q`.
fn nearest(sc: &Scenario, coil: usize, q: &Orientation) -> Pair {
    Pair {
        coil: CoilId(coil),
        magnet: nearest_magnet(&sc.torques, CoilId(coil), q).0,
    }
}

fn start() -> Orientation {
    rot_q(
        &unit(Vector3::new(0.2, 1.0, 0.4)).expect("axis"),
        Radians(0.08),
    )
}

/// The coils of the K-pair sets, in the order they are added.
const COILS: [usize; 8] = [0, 7, 12, 9, 3, 14, 5, 1];

fn set_of(sc: &Scenario, k: usize, q0: &Orientation) -> Vec<Pair> {
    COILS[..k].iter().map(|&c| nearest(sc, c, q0)).collect()
}

fn bench_settle(c: &mut Criterion) {
    let sc = load("scenarios/prototype.toml");
    let q0 = start();
    let mut g = c.benchmark_group("settle");
    for k in 2..=4 {
        let set = set_of(&sc, k, &q0);
        g.bench_with_input(BenchmarkId::new("pairs", k), &set, |b, set| {
            b.iter(|| settle(&sc.torques, black_box(set), &q0, sc.body, sc.settle))
        });
    }
    g.finish();

    let old = SettleParams {
        rtol: 1e-6,
        atol: 1e-8,
        method: Method::Dopri5,
        ..sc.settle
    };
    let set = set_of(&sc, 3, &q0);
    let mut g = c.benchmark_group("settle_dopri5");
    g.bench_with_input(BenchmarkId::new("pairs", 3), &set, |b, set| {
        b.iter(|| settle(&sc.torques, black_box(set), &q0, sc.body, old))
    });
    g.finish();

    let mut g = c.benchmark_group("rhs");
    let sys = RotorDynamics::new(&sc.torques, &set, sc.body);
    let y = turning(&q0);
    g.bench_function(BenchmarkId::new("pairs", 3), |b| {
        b.iter(|| rhs_once(&sys, &y))
    });
    g.finish();
}

/// The state the `rhs` benches evaluate at: orientation `q`, turning at (0.1, -0.2, 0.3) rad/s.
fn turning(q: &Orientation) -> [f64; 7] {
    [q.i, q.j, q.k, q.w, 0.1, -0.2, 0.3]
}

/// One right-hand-side evaluation.
fn rhs_once<M: TorqueModel>(sys: &RotorDynamics<'_, M>, y: &[f64; 7]) -> [f64; 7] {
    let mut dy = [0.0; 7];
    sys.rhs(black_box(y), &mut dy);
    dy
}

fn bench_growth(c: &mut Criterion) {
    let sc = load("scenarios/prototype.toml");
    let q0 = start();
    let mut g = c.benchmark_group("growth_pairs");
    for k in 2..=8 {
        let set = set_of(&sc, k, &q0);
        g.bench_with_input(BenchmarkId::from_parameter(k), &set, |b, set| {
            b.iter(|| settle(&sc.torques, black_box(set), &q0, sc.body, sc.settle))
        });
    }
    g.finish();

    let coils = [Pair::new(0, 0), Pair::new(7, 0)];
    let mut g = c.benchmark_group("growth_magnets_coils");
    g.sample_size(10);
    let mut rhs = Vec::new();
    for n in [20usize, 40, 80, 160, 320] {
        let torques = MagnetTorques {
            rotor: sphere_axes(n).iter().map(|a| a.into_inner()).collect(),
            interaction: Interaction::Coils,
            ..sc.torques.clone()
        };
        g.bench_with_input(BenchmarkId::from_parameter(n), &torques, |b, t| {
            b.iter(|| settle(t, black_box(&coils), &q0, sc.body, sc.settle))
        });
        rhs.push((n, torques));
    }
    g.finish();
    let mut g = c.benchmark_group("rhs_coils");
    for (n, torques) in &rhs {
        let sys = RotorDynamics::new(torques, &coils, sc.body);
        let y = turning(&q0);
        g.bench_function(BenchmarkId::from_parameter(n), |b| {
            b.iter(|| rhs_once(&sys, &y))
        });
    }
    g.finish();
}

fn bench_threads(c: &mut Criterion) {
    let sc = load("scenarios/prototype.toml");
    let q0 = start();
    let mut sets = Vec::new();
    'outer: for a in 0..16 {
        for b in 0..16 {
            for c3 in 0..16 {
                if a != b && b != c3 && a != c3 {
                    sets.push(vec![
                        nearest(&sc, a, &q0),
                        nearest(&sc, b, &q0),
                        nearest(&sc, c3, &q0),
                    ]);
                    if sets.len() == 1000 {
                        break 'outer;
                    }
                }
            }
        }
    }
    let mut g = c.benchmark_group("settle_many");
    g.sample_size(20);
    for threads in [1usize, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("a thread pool");
        g.bench_function(BenchmarkId::new("threads", threads), |b| {
            b.iter(|| {
                pool.install(|| settle_many(&sc.torques, black_box(&sets), &q0, sc.body, sc.settle))
            })
        });
    }
    g.finish();
}

fn bench_planner_sets(c: &mut Criterion) {
    let sc = load("benches/planner-sets.toml");
    let mut rng = basins_common::Rng::new(32);
    let sets = basins_common::planner_sets(&sc.torques, 4000, 24.0, &mut rng);
    let mut g = c.benchmark_group("settle_planner");
    g.sample_size(10);
    g.throughput(Throughput::Elements(sets.len() as u64));
    g.bench_function(BenchmarkId::new("sets", sets.len()), |b| {
        b.iter(|| {
            for (q0, set) in &sets {
                black_box(settle(&sc.torques, black_box(set), q0, sc.body, sc.settle));
            }
        })
    });
    g.finish();
}

fn bench_planner(c: &mut Criterion) {
    let sc = load("scenarios/paper-fig8-y-dynamic3.toml");
    let motor = sc.motor();
    let mut g = c.benchmark_group("plan_y_dynamic3");
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(8));
    for deg in [30.0, 60.0, 90.0, 120.0] {
        let mut s = sc.plan.clone();
        s.angle = Degrees(deg).to_radians();
        g.bench_with_input(BenchmarkId::new("angle", deg), &s, |b, s| {
            b.iter(|| plan(&motor, black_box(s)))
        });
    }
    g.finish();
}

fn bench_dipole(c: &mut Criterion) {
    let real = load("scenarios/prototype-physical.toml");
    let point = load("tests/data/prototype-physical-point.toml");
    let mut gaussian = load("scenarios/prototype.toml");
    gaussian.torques.interaction = Interaction::Coils;
    let q0 = start();
    let mut g = c.benchmark_group("dipole");
    for (name, sc) in [("real", &real), ("dipole", &point), ("gaussian", &gaussian)] {
        let three = set_of(sc, 3, &q0);
        let sys = RotorDynamics::new(&sc.torques, &three, sc.body);
        let y = turning(&q0);
        g.bench_function(BenchmarkId::new("rhs", name), |b| {
            b.iter(|| rhs_once(&sys, &y))
        });
        let two = set_of(sc, 2, &q0);
        g.bench_function(BenchmarkId::new("settle", name), |b| {
            b.iter(|| settle(&sc.torques, black_box(&two), &q0, sc.body, sc.settle))
        });
    }
    g.finish();
}

fn bench_coil_sets(c: &mut Criterion) {
    let sc = load("scenarios/soft-wells.toml");
    let q0 = start();
    let mut sets = Vec::new();
    for a in 0..8 {
        for b in a + 1..8 {
            for d in b + 1..8 {
                sets.push([a, b, d].map(|k| nearest(&sc, k, &q0)));
            }
        }
    }
    let mut g = c.benchmark_group("coil_sets");
    g.sample_size(10);
    g.throughput(Throughput::Elements(sets.len() as u64));
    g.bench_function(BenchmarkId::new("soft-wells", sets.len()), |b| {
        b.iter(|| {
            for set in &sets {
                black_box(settle(&sc.torques, black_box(set), &q0, sc.body, sc.settle));
            }
        })
    });
    g.finish();
}

criterion_group!(
    benches,
    bench_settle,
    bench_growth,
    bench_threads,
    bench_planner_sets,
    bench_planner,
    bench_dipole,
    bench_coil_sets
);
criterion_main!(benches);
