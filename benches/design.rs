//! Criterion benchmarks of one layout's evaluation in `spherestep design` (issue 56): the
//! prototype's layout (the first seed of `scenarios/design-prototype.toml`) planned about the
//! design's axes by its angle, serially, and its objectives taken:
//! - `design_evaluation/coarse`: the 32 coarse axes;
//! - `design_evaluation/full`: the 128 full axes.
//!
//! Run: `cargo bench --bench design` (about 10 samples of 8 s and of 32 s of CPU each on the
//! shared 2-core machine; `cargo bench --bench design -- coarse` for the coarse one alone).

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use spherestep::io::scenario::Scenario;
use spherestep::planning::design::objectives::{AxisResult, Objectives};
use spherestep::planning::plan::final_orientation_error_deg;
use spherestep::planning::planner::{max_axis_error_deg, plan, PlanSettings};
use std::time::Duration;

/// The objectives of the scenario's own layout about the first `count` design axes.
fn evaluate(sc: &Scenario, count: usize) -> Objectives {
    let spec = sc.design.as_ref().expect("a [design] section");
    let motor = sc.motor();
    let results: Vec<AxisResult> = spec
        .axes_of(count)
        .into_iter()
        .map(|axis| {
            let s = PlanSettings {
                axis,
                angle: spec.angle,
                ..sc.plan.clone()
            };
            let rows = plan(&motor, &s).rows;
            AxisResult {
                axis_error_deg: max_axis_error_deg(&rows),
                steps: rows.len().saturating_sub(1),
                final_error_deg: final_orientation_error_deg(&s, &rows),
            }
        })
        .collect();
    Objectives::from_axes(&results, sc.stator.len())
}

fn bench_evaluation(c: &mut Criterion) {
    let sc = Scenario::load(std::path::Path::new("scenarios/design-prototype.toml"))
        .expect("scenarios/design-prototype.toml loads");
    let spec = sc.design.clone().expect("a [design] section");
    let mut g = c.benchmark_group("design_evaluation");
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(60));
    for (name, count) in [("coarse", spec.axes), ("full", spec.full_axes)] {
        g.bench_function(name, |b| b.iter(|| evaluate(&sc, black_box(count))));
    }
    g.finish();
}

criterion_group!(benches, bench_evaluation);
criterion_main!(benches);
