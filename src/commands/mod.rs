//! The commands behind the command line, as library functions that take plain arguments and
//! write to a given output, so that they are testable without spawning the binary. The entry
//! points, one per command: [`settle_one`] and [`settle_sets`] (`settle`), [`plan_command`]
//! (`plan`; [`waypoints::plan_waypoints_command`] with `--waypoints`,
//! [`excite::excite_command`] with `--excite`), [`simulate_plan`]
//! (`simulate`; [`closed_loop::simulate_closed_loop`] with `--closed-loop`),
//! [`closed_loop::run_command`] (`run`), [`replay::run`] and [`closed_replay::run`] (`replay`,
//! open and closed loop), [`rehearse::run`] (`virtual`), [`wells::wells_command`] (`wells`),
//! [`packing_report`] (`packing`), [`write_prototype`] (`prototype`) and
//! [`batch::run_batch`] (`batch`), [`design::run_design`] (`design`, with the `design`
//! feature); [`args`] parses the typed arguments they share.

pub mod args;
pub mod batch;
pub mod closed_loop;
pub mod closed_replay;
#[cfg(feature = "design")]
pub mod design;
pub mod excite;
pub mod fit;
pub mod rehearse;
pub mod replay;
pub mod waypoints;
pub mod wells;

use crate::error::{Error, Result};
use crate::io::output::emit_csv;
use crate::io::pairs::parse_pairs;
use crate::io::planfile::write_plan;
use crate::io::scenario::{
    parse_pairs_per_step, ChangeNames, PlanChanges, PlanInput, RowsFrom, Scenario,
};
use crate::io::table::write_csv;
use crate::model::geometry::{xyzw, Orientation, Pair};
use crate::model::packing::{self, points_csv};
use crate::physics::dynamics::{settle, settle_many, SettleResult};
pub use crate::planning::holding::Holding;
use crate::planning::plan::PlanRow;
use crate::planning::planner::{plan, Plan, PlanSettings};
use crate::planning::simulate::{simulate, SimRow};
use crate::text::printable;
use args::{parse_axis, parse_orientation};
use std::io::Write;
use std::path::Path;

fn write_err(path: &str) -> impl Fn(std::io::Error) -> Error + '_ {
    move |e| Error::io(path, e)
}

/// `bar` drawn with `template` (indicatif's template; its default look if the template does
/// not parse): the one style of every progress bar the commands draw on standard error.
pub(crate) fn styled(bar: indicatif::ProgressBar, template: &str) -> indicatif::ProgressBar {
    bar.with_style(
        indicatif::ProgressStyle::with_template(template)
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    )
}

/// `spherestep packing`: the compatibility report of a scenario's rotor and stator.
pub fn packing_report(sc: &Scenario, json: bool, out: &mut dyn Write) -> Result<()> {
    let r = packing::report(&sc.rotor, &sc.stator);
    let w = write_err("<stdout>");
    if json {
        let s =
            serde_json::to_string_pretty(&r).map_err(|e| Error::json("the packing report", e))?;
        writeln!(out, "{s}").map_err(&w)?;
        return Ok(());
    }
    writeln!(out, "scenario: {}", printable(&sc.name)).map_err(&w)?;
    writeln!(
        out,
        "rotor: {} magnets, minimum separation {:.3} deg",
        r.rotor_magnets, r.rotor_min_separation_deg
    )
    .map_err(&w)?;
    writeln!(
        out,
        "stator: {} coils, minimum separation {:.3} deg, cap radius about -Z {:.3} deg",
        r.stator_coils, r.stator_min_separation_deg, r.stator_cap_radius_deg
    )
    .map_err(&w)?;
    writeln!(
        out,
        "rotor center lengths: {} distinct (merged within {} deg)",
        r.rotor_center_lengths_deg.len(),
        packing::CENTER_LENGTH_TOL.0
    )
    .map_err(&w)?;
    writeln!(out, "stator center lengths against the nearest rotor ones:").map_err(&w)?;
    writeln!(
        out,
        "{:>12} {:>8} {:>14} {:>14}",
        "stator_deg", "pairs", "rotor_deg", "mismatch_deg"
    )
    .map_err(&w)?;
    for m in &r.stator_center_lengths {
        writeln!(
            out,
            "{:>12.3} {:>8} {:>14.3} {:>14.3}",
            m.stator_deg, m.stator_pairs, m.nearest_rotor_deg, m.mismatch_deg
        )
        .map_err(&w)?;
    }
    writeln!(out, "worst mismatch: {:.3} deg", r.worst_mismatch_deg).map_err(&w)?;
    Ok(())
}

/// Regenerates the prototype's coordinate files (rotor.csv, stator.csv) into `dir`.
pub fn write_prototype(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    for (name, p) in [
        ("rotor.csv", packing::generate_prototype_rotor()),
        ("stator.csv", packing::generate_prototype_stator()),
    ] {
        let path = dir.join(name);
        std::fs::write(&path, points_csv(&p)).map_err(|e| Error::io(&path, e))?;
    }
    Ok(())
}

/// One settle result as a JSON object with the documented keys.
pub fn settle_json(r: &SettleResult, h: &Holding) -> serde_json::Value {
    serde_json::json!({
        "q": xyzw(&r.q),
        "settle_time_s": r.settle_time_s,
        "arrival_time_s": r.arrival_time_s,
        "evaluations": r.evaluations,
        "steps": r.steps,
        "energy_j": r.energy_j,
        "residual_torque_nm": r.residual_torque_nm,
        "settled": r.settled,
        "stop": r.stop.describe(),
        "held": active_text(&h.held),
        "not_held": active_text(&h.not_held),
        "outcome": h.outcome(r.settled),
    })
}

/// Text form of an active set in files: `coil:magnet;coil:magnet`.
fn or_none(pairs: &[Pair]) -> String {
    match pairs.is_empty() {
        true => "none".into(),
        false => active_text(pairs),
    }
}

/// The pairs as a plan file writes its `active` column.
pub(crate) fn active_text(active: &[Pair]) -> String {
    crate::model::geometry::pairs_text(active)
}

/// `spherestep settle --pairs`: settles one active set and prints the result.
pub fn settle_one(
    sc: &Scenario,
    pairs: &str,
    from: &Orientation,
    json: bool,
    out: &mut dyn Write,
) -> Result<SettleResult> {
    let active = parse_pairs(pairs, "--pairs")?;
    sc.check_active(&active, "--pairs")?;
    let r = settle(&sc.torques, &active, from, sc.body, sc.settle);
    let h = Holding::of(&sc.torques, &active, &r.q);
    let w = write_err("<stdout>");
    if json {
        writeln!(out, "{}", settle_json(&r, &h)).map_err(&w)?;
    } else {
        let q = xyzw(&r.q);
        writeln!(out, "active: {}", active_text(&active)).map_err(&w)?;
        writeln!(
            out,
            "q (qx, qy, qz, qw): {:.9}, {:.9}, {:.9}, {:.9}",
            q[0], q[1], q[2], q[3]
        )
        .map_err(&w)?;
        writeln!(
            out,
            "settled: {}  at t = {:.6} s  ({} evaluations, {} steps)",
            if r.settled {
                "yes".to_string()
            } else {
                format!("NO ({})", r.stop.describe())
            },
            r.settle_time_s,
            r.evaluations,
            r.steps
        )
        .map_err(&w)?;
        writeln!(
            out,
            "arrived: within {:.3} deg of its rest from t = {:.6} s",
            sc.settle.arrival.to_degrees().0,
            r.arrival_time_s
        )
        .map_err(&w)?;
        writeln!(
            out,
            "outcome: {}  (holding: {}; out of reach: {})",
            h.outcome(r.settled),
            or_none(&h.held),
            or_none(&h.not_held)
        )
        .map_err(&w)?;
        // ordinary energies to the nanojoule, extreme ones (an overflowing well) in exponent form
        let energy = match r.energy_j.abs() {
            e if e.is_finite() && e < 1e15 => format!("{:.9}", r.energy_j),
            _ => format!("{:.6e}", r.energy_j),
        };
        writeln!(
            out,
            "energy: {energy} J  residual torque: {:.3e} N m",
            r.residual_torque_nm
        )
        .map_err(&w)?;
    }
    Ok(r)
}

/// Header of the CSV written by `settle --sets`.
pub const SETS_HEADER: [&str; 15] = [
    "line",
    "active",
    "qx",
    "qy",
    "qz",
    "qw",
    "settle_time_s",
    "arrival_time_s",
    "evaluations",
    "steps",
    "energy_j",
    "residual_torque_nm",
    "settled",
    "held",
    "outcome",
];

/// Reads a sets file: one active set per non-empty line (`#` starts a comment), each checked.
pub fn read_sets(sc: &Scenario, path: &Path) -> Result<Vec<Vec<Pair>>> {
    let text = crate::io::input::text(path)?;
    let mut sets = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let row = |e: Error| Error::Row {
            file: path.to_path_buf(),
            line: i + 1,
            message: e.to_string(),
        };
        let set = parse_pairs(line, "active set").map_err(row)?;
        sc.check_active(&set, "active set").map_err(row)?;
        sets.push(set);
    }
    Ok(sets)
}

/// `spherestep settle --sets FILE`: settles every set in parallel, writes one CSV row per set,
/// in the file's order.
pub fn settle_sets(
    sc: &Scenario,
    sets: &[Vec<Pair>],
    from: &Orientation,
    out: &mut dyn Write,
) -> Result<Vec<SettleResult>> {
    let results = settle_many(&sc.torques, sets, from, sc.body, sc.settle);
    let record = |(k, (set, r)): (usize, (&Vec<Pair>, &SettleResult))| {
        let q = xyzw(&r.q);
        let h = Holding::of(&sc.torques, set, &r.q);
        vec![
            (k + 1).to_string(),
            active_text(set),
            q[0].to_string(),
            q[1].to_string(),
            q[2].to_string(),
            q[3].to_string(),
            r.settle_time_s.to_string(),
            r.arrival_time_s.to_string(),
            r.evaluations.to_string(),
            r.steps.to_string(),
            r.energy_j.to_string(),
            r.residual_torque_nm.to_string(),
            r.settled.to_string(),
            active_text(&h.held),
            h.outcome(r.settled).to_string(),
        ]
    };
    let records = sets.iter().zip(&results).enumerate().map(record);
    write_csv(out, "<settle output>", &SETS_HEADER, records)?;
    Ok(results)
}

/// Command-line overrides of a scenario's `[plan]` section.
#[derive(Debug, Clone, Default)]
pub struct PlanOverrides {
    /// `--axis`: the desired rotation axis, `x,y,z` in the world frame.
    pub axis: Option<String>,
    /// `--angle`: the target rotation angle, degrees.
    pub angle_deg: Option<f64>,
    /// `--scheme`: the planner's scheme by name (min-axis-error, max-angle, weighted or search).
    pub scheme: Option<String>,
    /// `--model`: the step model by name (pivot, dynamic, coils).
    pub model: Option<String>,
    /// `K` (exactly K pairs after each step) or `2-K` (2 to K, chosen per step).
    pub pairs: Option<String>,
    /// `--from`: the start orientation, `qx,qy,qz,qw`.
    pub from: Option<String>,
    /// A target orientation `qx,qy,qz,qw` instead of `axis` and `angle_deg`.
    pub to: Option<String>,
}

/// What the command line calls each change of the plan settings.
pub const OPTION_NAMES: ChangeNames = ChangeNames {
    axis: "--axis",
    angle: "--angle",
    scheme: "--scheme",
    model: "--model",
    pairs: "--pairs",
    start: "--from",
    to: "--to",
};

/// Applies command-line overrides to plan settings, checking each: the options read as their
/// types here, the changes made and checked by [`Scenario::plan_with`].
pub fn plan_settings(sc: &Scenario, o: &PlanOverrides) -> Result<PlanSettings> {
    let n = &OPTION_NAMES;
    let pairs = |k: &String| {
        parse_pairs_per_step(k).ok_or_else(|| Error::Arg {
            arg: n.pairs.into(),
            expected: format!("K (exactly K pairs per step) or 2-K (2 to K), got '{k}'"),
        })
    };
    let changes = PlanChanges {
        axis: o.axis.as_ref().map(|a| parse_axis(a, n.axis)).transpose()?,
        angle_deg: o.angle_deg,
        scheme: o.scheme.as_deref(),
        model: o.model.as_deref(),
        pairs: o.pairs.as_ref().map(pairs).transpose()?,
        start: o
            .from
            .as_ref()
            .map(|f| parse_orientation(f, n.start))
            .transpose()?,
        to: o
            .to
            .as_ref()
            .map(|t| parse_orientation(t, n.to))
            .transpose()?,
    };
    sc.plan_with(&changes, n)
}

/// `spherestep plan`: plans, writes the CSV (atomically) to `out_file` when asked and prints
/// the summary to `out`; without `out_file` (and without `json`) the CSV alone goes to `out`
/// and the summary line to `note`, so that `plan ... > plan.csv` gives a plan file.
pub fn plan_command(
    sc: &Scenario,
    settings: &PlanSettings,
    out_file: Option<&Path>,
    json: bool,
    out: &mut dyn Write,
    note: &mut dyn Write,
) -> Result<Plan> {
    let p = plan(&sc.motor(), settings);
    let mut csv = Vec::new();
    write_plan(&p.rows, &mut csv)?;
    let out = emit_csv(&csv, out_file, json, out, note)?;
    let s = p.summary(settings);
    let w = write_err("<stdout>");
    if json {
        writeln!(
            out,
            "{}",
            serde_json::to_string(&s).map_err(|e| Error::json("the plan summary", e))?
        )
        .map_err(&w)?;
    } else {
        let ax = settings.axis;
        let mut text = format!(
            "{}: {} steps about [{:.4}, {:.4}, {:.4}] by {:.2} deg ({} model, {} {}, {}): \
             final angle {:.2} deg, worst axis error {:.2} deg, path deviation {:.2} deg, {:.2} \
             deg from the target orientation, {}",
            printable(&sc.name),
            s.steps,
            ax.x,
            ax.y,
            ax.z,
            settings.angle.0.to_degrees(),
            s.model,
            settings.pairs,
            settings.model.unit(),
            s.scheme,
            s.final_angle_deg,
            s.max_axis_error_deg,
            s.max_path_deviation_deg,
            s.final_orientation_error_deg,
            if s.reached { "reached" } else { "NOT reached" }
        );
        if let Some(m) = &p.message {
            text.push_str(&format!(": {m}"));
        }
        writeln!(out, "{text}").map_err(&w)?;
        if let Some(warning) = unsettled_warning(&s.unsettled_steps, sc.settle.t_max) {
            writeln!(out, "{warning}").map_err(&w)?;
        }
    }
    Ok(p)
}

/// The warning for a plan's steps that do not settle within t_max (`None` when all do).
pub fn unsettled_warning(steps: &[usize], t_max: f64) -> Option<String> {
    let (last, rest) = steps.split_last()?;
    let list = match rest.is_empty() {
        true => format!("step {last}"),
        false => {
            let rest: Vec<String> = rest.iter().map(|k| k.to_string()).collect();
            format!("steps {} and {last}", rest.join(", "))
        }
    };
    Some(format!(
        "warning: {list} never settled within t_max ({} s): the settle time written is t_max, \
         not a settle time (settled = false in the CSV); `simulate` shows where the ball goes",
        crate::text::shown(t_max)
    ))
}

/// Reads the plan at `plan_path`, checks its pairs against the scenario and replays it in the
/// scenario's physics (`spherestep simulate`).
pub fn simulate_plan(sc: &Scenario, plan_path: &Path) -> Result<Vec<SimRow>> {
    simulate_plan_in(sc, None, plan_path)
}

/// Checks the pairs of a plan read from `plan_path` against the scenario it is played in: an
/// error names the plan's line and the scenario.
pub fn check_plan_pairs(sc: &Scenario, rows: &[PlanRow], plan_path: &Path) -> Result<()> {
    sc.check_plan_pairs(rows, RowsFrom::File(plan_path))
}

/// Reads the plan at `plan_path` made for `sc`, checks its pairs against it and replays it in
/// the physics of `plant` (`spherestep simulate --plant`: the model error of a plan made for
/// one physics and run on another), or of `sc` itself. A plant with other packings than the
/// plan's is refused.
pub fn simulate_plan_in(
    sc: &Scenario,
    plant: Option<&Scenario>,
    plan_path: &Path,
) -> Result<Vec<SimRow>> {
    let rows = sc.checked_rows(PlanInput::File(plan_path))?;
    let physics = match plant {
        Some(p) => {
            sc.check_same_packings(p, "--plant")?;
            p
        }
        None => sc,
    };
    Ok(simulate(&physics.motor(), &rows))
}
