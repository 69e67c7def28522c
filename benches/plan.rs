//! Criterion benchmarks of the default planner (dynamic model, 2 to 4 pairs per step,
//! best-first search) on the built-in prototype:
//! - `plan_default/axis/NAME`: one 90 degree plan about a fixed axis: Z (a coil on the axis),
//!   Y (a rim coil 10.8 degrees from it), X and X+Y (in the X-Y plane, far from every coil's
//!   axis line: the hard cases).
//!
//! Run: `cargo bench --bench plan`.

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion};
use nalgebra::Vector3;
use spherestep::io::scenario::Scenario;
use spherestep::model::geometry::UnitVec;
use spherestep::planning::planner::plan;
use std::time::Duration;

fn bench_default_planner(c: &mut Criterion) {
    let sc = Scenario::load(std::path::Path::new("scenarios/prototype.toml"))
        .expect("scenarios/prototype.toml loads");
    let motor = sc.motor();
    let mut g = c.benchmark_group("plan_default");
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(6));
    for (name, v) in [
        ("Z", Vector3::new(0.0, 0.0, 1.0)),
        ("Y", Vector3::new(0.0, 1.0, 0.0)),
        ("X", Vector3::new(1.0, 0.0, 0.0)),
        ("X+Y", Vector3::new(1.0, 1.0, 0.0)),
    ] {
        let mut s = sc.plan.clone();
        s.axis = UnitVec::new_normalize(v);
        g.bench_with_input(BenchmarkId::new("axis", name), &s, |b, s| {
            b.iter(|| plan(&motor, black_box(s)))
        });
    }
    g.finish();
}

criterion_group!(benches, bench_default_planner);
criterion_main!(benches);
