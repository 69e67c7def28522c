//! Criterion benchmarks of the settle engine on the built-in prototype: one settle of a 2-, 3-
//! and 4-pair set, and `settle_many` over 1,000 sets (on the rayon pool: all cores).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use nalgebra::Vector3;
use spherestep::dynamics::{settle, settle_many};
use spherestep::geometry::{angular_distance, rot_q, unit, Orientation, Pair, Radians, UnitVec};
use spherestep::scenario::Scenario;
use std::hint::black_box;

fn nearest(sc: &Scenario, coil: usize, q: &Orientation) -> Pair {
    let s = sc.stator.points[coil];
    let (j, _) = sc
        .rotor
        .points
        .iter()
        .enumerate()
        .map(|(j, r)| {
            (
                j,
                angular_distance(&UnitVec::new_normalize(q * r.into_inner()), &s).0,
            )
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .expect("magnets");
    Pair::new(coil, j)
}

fn start() -> Orientation {
    rot_q(
        &unit(Vector3::new(0.2, 1.0, 0.4)).expect("axis"),
        Radians(0.08),
    )
}

fn bench_settle(c: &mut Criterion) {
    let sc = Scenario::load(std::path::Path::new("scenarios/prototype.toml")).expect("scenario");
    let q0 = start();
    let coils = [0usize, 7, 12, 9];
    let mut g = c.benchmark_group("settle");
    for k in 2..=4 {
        let set: Vec<Pair> = coils[..k].iter().map(|&c| nearest(&sc, c, &q0)).collect();
        g.bench_with_input(BenchmarkId::new("pairs", k), &set, |b, set| {
            b.iter(|| settle(&sc.torques, black_box(set), &q0, sc.body, sc.settle))
        });
    }
    g.finish();

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
    g.sample_size(10);
    g.bench_function("1000_sets_3_pairs", |b| {
        b.iter(|| settle_many(&sc.torques, black_box(&sets), &q0, sc.body, sc.settle))
    });
    g.finish();
}

criterion_group!(benches, bench_settle);
criterion_main!(benches);
