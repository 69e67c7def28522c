//! `spherestep view`: one self-contained HTML page that shows a plan in 3-D.
//!
//! The page holds the scenario's packings (rotor magnets in the body frame, stator coils in the
//! world frame), every step of the plan (orientation, active pairs, the CSV's figures of merit,
//! the step's and the cumulative rotation axes), the desired axis and, optionally, `simulate`
//! results drawn as a ghost ball. The page's markup, style and script are files in the
//! repository (`assets/view/`), embedded into the binary with `include_str!`; the data is
//! embedded as JSON (`<script type="application/json" id="spherestep-data">`). The page loads
//! nothing from the network: its small canvas renderer is part of `view.js`.
//!
//! The page is written with `output::write_atomic` (a temporary file next to the output, then
//! a rename), so an error never leaves a half-written page behind.

use crate::error::{Error, Input, Result};
use crate::io::planfile::read_plan;
use crate::io::scenario::Scenario;
use crate::io::simfile::{read_sim, SimRecord};
use crate::model::geometry::{rotation_angle, rotation_axis, xyzw, Pair, UnitVec};
use crate::planning::plan::PlanRow;
use serde::Serialize;
use std::path::Path;

/// The page template; `{{STYLE}}`, `{{SCRIPT}}` and `{{DATA}}` are filled in.
pub const TEMPLATE: &str = include_str!("../../assets/view/view.html");
/// The page's style sheet.
pub const STYLE: &str = include_str!("../../assets/view/view.css");
/// The page's script: the renderer, the controls and the `#selftest` hook.
pub const SCRIPT: &str = include_str!("../../assets/view/view.js");

/// Where the desired axis shown on the page comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum AxisSource {
    /// Given on the command line (`--axis`).
    Given,
    /// Inferred as the axis of the plan's last cumulative rotation.
    Inferred,
}

/// What to show besides the plan.
#[derive(Debug, Clone, Default)]
pub struct ViewOptions {
    /// The desired rotation axis (world frame), when known.
    pub axis: Option<UnitVec>,
    /// Simulate results, one row per simulated step.
    pub sim: Option<Vec<SimRecord>>,
    /// A title for the page (default: "spherestep plan").
    pub title: Option<String>,
}

/// The data embedded in the page (read by `view.js`).
#[derive(Debug, Clone, Serialize)]
pub struct ViewData {
    /// The format of this data, for `view.js` (1).
    pub version: u32,
    /// The page's title.
    pub title: String,
    /// The scenario's name.
    pub scenario: String,
    /// Rotor magnets, body frame, unit vectors.
    pub rotor: Vec<[f64; 3]>,
    /// Stator coils, world frame, unit vectors.
    pub stator: Vec<[f64; 3]>,
    /// The desired rotation axis, world frame, when given or inferred.
    pub desired_axis: Option<DesiredAxis>,
    /// The plan's steps, row 0 (the initial commutation state) first.
    pub steps: Vec<ViewStep>,
    /// Simulated orientations, when given (not every step needs one).
    pub sim: Option<Vec<ViewSim>>,
}

/// The desired axis and where it came from.
#[derive(Debug, Clone, Serialize)]
pub struct DesiredAxis {
    /// The axis, world frame, unit vector.
    pub axis: [f64; 3],
    /// Where it came from.
    pub source: AxisSource,
}

/// One plan step as the page shows it.
#[derive(Debug, Clone, Serialize)]
pub struct ViewStep {
    /// The plan row's step number (0: the initial commutation state).
    pub step: usize,
    /// Orientation after the step, (qx, qy, qz, qw), body to world.
    pub q: [f64; 4],
    /// Energised pairs after the step, as [coil, magnet].
    pub active: Vec<[usize; 2]>,
    /// The pivot pair held through the step, as [coil, magnet] (none for row 0 or the coil-set
    /// model).
    pub pivot: Option<[usize; 2]>,
    /// The pairs switched on by the step, as [coil, magnet].
    pub new: Vec<[usize; 2]>,
    /// The step's rotation angle, degrees (the plan file's `step_angle_deg`).
    pub step_angle_deg: f64,
    /// The step's axis error, degrees (`step_axis_error_deg`).
    pub step_axis_error_deg: f64,
    /// The cumulative rotation angle after the step, degrees (`cum_angle_deg`).
    pub cum_angle_deg: f64,
    /// The cumulative axis error after the step, degrees (`cum_axis_error_deg`).
    pub cum_axis_error_deg: f64,
    /// The step's predicted settle time, seconds (`settle_time_s`).
    pub settle_time_s: f64,
    /// Axis of this step's rotation R_k R_{k-1}^T (none for step 0 or a zero step).
    pub step_axis: Option<[f64; 3]>,
    /// Axis of the cumulative rotation R_k R_0^T (none while it is the identity).
    pub cum_axis: Option<[f64; 3]>,
    /// Angle of the cumulative rotation computed from the quaternions, degrees.
    pub cum_angle_from_q_deg: f64,
}

/// One simulated orientation as the page shows it.
#[derive(Debug, Clone, Serialize)]
pub struct ViewSim {
    /// The plan step the orientation was simulated for.
    pub step: usize,
    /// The simulated orientation after the step, (qx, qy, qz, qw), body to world.
    pub q: [f64; 4],
    /// Angle between the simulated and the predicted orientation, degrees: the file's
    /// `deviation_deg` when it has one, else computed from the quaternions.
    pub deviation_deg: f64,
    /// The angle computed from the quaternions, degrees.
    pub computed_deviation_deg: f64,
}

fn v3(u: &UnitVec) -> [f64; 3] {
    [u.x, u.y, u.z]
}

fn pair(p: &Pair) -> [usize; 2] {
    [p.coil.0, p.magnet.0]
}

/// Builds the page's data from a plan (`plan_path` names it in errors), the scenario and the
/// options. Pair indices are checked against the scenario's packings, sim steps against the
/// plan's length.
pub fn view_data(
    plan: &[PlanRow],
    plan_path: &Path,
    sc: &Scenario,
    opts: &ViewOptions,
) -> Result<ViewData> {
    let first = plan.first().ok_or_else(|| Error::Row {
        file: plan_path.to_path_buf(),
        line: 2,
        message: "expected at least one step row".into(),
    })?;
    let mut steps = Vec::with_capacity(plan.len());
    for (i, r) in plan.iter().enumerate() {
        // Rows are one line each (no quoted newlines in a plan), so row i is on line i + 2.
        check_pairs(r, i + 2, plan_path, sc)?;
        let previous = i.checked_sub(1).map(|k| &plan[k]);
        steps.push(view_step(r, previous, first));
    }
    let sim = match &opts.sim {
        None => None,
        Some(rows) => Some(view_sim(rows, plan, first)?),
    };
    Ok(ViewData {
        version: 1,
        title: opts
            .title
            .clone()
            .unwrap_or_else(|| "spherestep plan".to_string()),
        scenario: sc.name.clone(),
        rotor: sc.rotor.points.iter().map(v3).collect(),
        stator: sc.stator.points.iter().map(v3).collect(),
        desired_axis: desired_axis(opts.axis.as_ref(), plan, first),
        steps,
        sim,
    })
}

/// Checks that every pair of plan row `r` (on line `line` of the plan file) names a coil and a
/// magnet of the scenario.
fn check_pairs(r: &PlanRow, line: usize, plan_path: &Path, sc: &Scenario) -> Result<()> {
    for p in r.active.iter().chain(&r.new).chain(r.pivot.iter()) {
        let bad = if p.coil.0 >= sc.stator.len() {
            Some(format!(
                "coil {} is beyond the scenario's {} coils (0-based)",
                p.coil,
                sc.stator.len()
            ))
        } else if p.magnet.0 >= sc.rotor.len() {
            Some(format!(
                "magnet {} is beyond the scenario's {} magnets (0-based)",
                p.magnet,
                sc.rotor.len()
            ))
        } else {
            None
        };
        if let Some(m) = bad {
            return Err(Error::Row {
                file: plan_path.to_path_buf(),
                line,
                message: format!("pair {p}: {m} (scenario {})", sc.path.display()),
            });
        }
    }
    Ok(())
}

/// Plan row `r` as the page shows it, with the axis of its step from the `previous` row (none
/// for the first) and of its cumulative rotation from the `first`.
fn view_step(r: &PlanRow, previous: Option<&PlanRow>, first: &PlanRow) -> ViewStep {
    let step_axis = previous
        .and_then(|p| rotation_axis(&(r.q * p.q.inverse())))
        .map(|a| v3(&a));
    let cum = r.q * first.q.inverse();
    ViewStep {
        step: r.step,
        q: xyzw(&r.q),
        active: r.active.iter().map(pair).collect(),
        pivot: r.pivot.as_ref().map(pair),
        new: r.new.iter().map(pair).collect(),
        step_angle_deg: r.step_angle_deg,
        step_axis_error_deg: r.step_axis_error_deg,
        cum_angle_deg: r.cum_angle_deg,
        cum_axis_error_deg: r.cum_axis_error_deg,
        settle_time_s: r.settle_time_s,
        step_axis,
        cum_axis: rotation_axis(&cum).map(|a| v3(&a)),
        cum_angle_from_q_deg: rotation_angle(&cum).0.to_degrees(),
    }
}

/// The desired axis: the one `given`, else the axis of the plan's whole rotation from its
/// `first` row to its last (none if that is the identity).
fn desired_axis(given: Option<&UnitVec>, plan: &[PlanRow], first: &PlanRow) -> Option<DesiredAxis> {
    match given {
        Some(a) => Some(DesiredAxis {
            axis: v3(a),
            source: AxisSource::Given,
        }),
        None => plan
            .last()
            .and_then(|r| rotation_axis(&(r.q * first.q.inverse())))
            .map(|a| DesiredAxis {
                axis: v3(&a),
                source: AxisSource::Inferred,
            }),
    }
}

/// The simulated orientations as the page shows them, each matched by step number to the
/// plan's row (`first` its first) and their deviation from it (an error for a step the plan
/// does not have).
fn view_sim(rows: &[SimRecord], plan: &[PlanRow], first: &PlanRow) -> Result<Vec<ViewSim>> {
    let last = plan.last().map(|r| r.step).unwrap_or(first.step);
    let mut out = Vec::with_capacity(rows.len());
    for s in rows {
        let planned = plan
            .iter()
            .find(|r| r.step == s.step)
            .ok_or_else(|| Error::Input {
                input: Input::Simulation,
                expected: format!(
                    "steps of the plan ({}..={last}), got step {}",
                    first.step, s.step
                ),
            })?;
        let computed = s.q.angle_to(&planned.q).to_degrees();
        out.push(ViewSim {
            step: s.step,
            q: xyzw(&s.q),
            deviation_deg: s.deviation_deg.unwrap_or(computed),
            computed_deviation_deg: computed,
        });
    }
    Ok(out)
}

/// The data as JSON safe to embed in an HTML `<script>` element: `<`, `>` and `&` are written
/// as JSON escapes (they can only occur inside strings), so no `</script>` can end it early.
pub fn data_json(data: &ViewData) -> Result<String> {
    let s = serde_json::to_string(data).map_err(|e| Error::Arg {
        arg: "view data".into(),
        expected: format!("data that serialises to JSON: {e}"),
    })?;
    Ok(s.replace('<', "\\u003c")
        .replace('>', "\\u003e")
        .replace('&', "\\u0026"))
}

/// Fills the template's `{{NAME}}` markers in one pass (inserted text is never rescanned).
fn fill(template: &str, values: &[(&str, &str)]) -> String {
    let mut out =
        String::with_capacity(template.len() + values.iter().map(|v| v.1.len()).sum::<usize>());
    let mut rest = template;
    while let Some(start) = rest.find("{{") {
        out.push_str(&rest[..start]);
        let after = &rest[start + 2..];
        match after.find("}}").and_then(|end| {
            let name = &after[..end];
            values
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(_, v)| (end, *v))
        }) {
            Some((end, v)) => {
                out.push_str(v);
                rest = &after[end + 2..];
            }
            None => {
                out.push_str("{{");
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out
}

/// The whole page for the given data.
pub fn render_html(data: &ViewData) -> Result<String> {
    let json = data_json(data)?;
    Ok(fill(
        TEMPLATE,
        &[("STYLE", STYLE), ("SCRIPT", SCRIPT), ("DATA", &json)],
    ))
}

/// `spherestep view`: reads the plan (and the simulate results, if any), builds the page and
/// writes it to `out`. On any error nothing is written.
pub fn write_view(
    plan_path: &Path,
    sc: &Scenario,
    sim_path: Option<&Path>,
    axis: Option<UnitVec>,
    out: &Path,
) -> Result<ViewData> {
    let plan = read_plan(plan_path)?;
    let sim = sim_path.map(read_sim).transpose()?;
    let title = plan_path
        .file_name()
        .map(|n| format!("spherestep plan: {}", n.to_string_lossy()));
    let data = view_data(&plan, plan_path, sc, &ViewOptions { axis, sim, title })?;
    let html = render_html(&data)?;
    crate::io::output::write_atomic(out, html.as_bytes())?;
    Ok(data)
}

/// Extracts the embedded data JSON from a page written by [`render_html`] (for tests and
/// tools), or `None` if the page has none.
pub fn extract_data_json(html: &str) -> Option<&str> {
    let marker = "id=\"spherestep-data\"";
    let at = html.find(marker)?;
    let open_end = at + html[at..].find('>')? + 1;
    let close = open_end + html[open_end..].find("</script>")?;
    Some(html[open_end..close].trim())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::simfile::parse_sim;
    use crate::model::geometry::rot_q;
    use crate::model::geometry::{unit, Radians};
    use nalgebra::Vector3;

    fn z() -> UnitVec {
        unit(Vector3::new(0.0, 0.0, 1.0)).expect("unit z")
    }

    fn plan() -> Vec<PlanRow> {
        (0..4)
            .map(|k| PlanRow {
                step: k,
                pivot: (k > 0).then(|| Pair::new(0, 5)),
                new: vec![Pair::new(3 + k, 17)],
                active: vec![Pair::new(0, 5), Pair::new(3 + k, 17)],
                q: rot_q(&z(), Radians(0.1 * k as f64)),
                step_angle_deg: if k > 0 { 5.73 } else { 0.0 },
                step_axis_error_deg: 0.1,
                cum_angle_deg: 5.73 * k as f64,
                cum_axis_error_deg: 0.2,
                settle_time_s: 0.3,
                settled: true,
            })
            .collect()
    }

    #[test]
    fn data_has_axes_and_steps() {
        let sc = Scenario::prototype();
        let d = view_data(&plan(), Path::new("p.csv"), &sc, &ViewOptions::default()).unwrap();
        assert_eq!(d.steps.len(), 4);
        assert_eq!(d.rotor.len(), sc.rotor.len());
        assert_eq!(d.stator.len(), sc.stator.len());
        assert!(d.steps[0].step_axis.is_none() && d.steps[0].cum_axis.is_none());
        let a = d.steps[2].step_axis.unwrap();
        assert!((a[2] - 1.0).abs() < 1e-12, "{a:?}");
        assert!((d.steps[3].cum_angle_from_q_deg - 0.3f64.to_degrees()).abs() < 1e-9);
        let da = d.desired_axis.unwrap();
        assert_eq!(da.source, AxisSource::Inferred);
        assert!((da.axis[2] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn bad_pair_index_names_the_line() {
        let sc = Scenario::prototype();
        let mut p = plan();
        p[2].active[1] = Pair::new(99, 1);
        let e = view_data(&p, Path::new("p.csv"), &sc, &ViewOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("p.csv: line 4") && e.contains("coil 99"), "{e}");
    }

    /// The page's data for [`plan`] on the prototype, with simulate results `sim`.
    fn view_data_with_sim(sim: Vec<SimRecord>) -> Result<ViewData> {
        let opts = ViewOptions {
            sim: Some(sim),
            ..Default::default()
        };
        view_data(&plan(), Path::new("p.csv"), &Scenario::prototype(), &opts)
    }

    #[test]
    fn sim_file_is_checked_and_matched() {
        let e = parse_sim("step,qx,qy,qz\n0,0,0,0\n", Path::new("s.csv"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("`qw`"), "{e}");
        let e = parse_sim(
            "step,qx,qy,qz,qw\n0,0,0,0,1\n1,0,0,x,1\n",
            Path::new("s.csv"),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("line 3") && e.contains("`qz`"), "{e}");
        let rows = parse_sim(
            "t,step,qx,qy,qz,qw,deviation_deg\n0.1,1,0,0,0.0499792,0.99875,\n0.2,2,0,0,0,1,7.5\n",
            Path::new("s.csv"),
        )
        .unwrap();
        let d = view_data_with_sim(rows).unwrap();
        let sim = d.sim.unwrap();
        assert!(sim[0].deviation_deg < 1e-3, "{:?}", sim[0]);
        assert_eq!(sim[1].deviation_deg, 7.5);
        assert!((sim[1].computed_deviation_deg - 0.2f64.to_degrees()).abs() < 1e-9);
        let far = parse_sim("step,qx,qy,qz,qw\n9,0,0,0,1\n", Path::new("s.csv")).unwrap();
        let e = view_data_with_sim(far).unwrap_err().to_string();
        assert!(e.contains("`sim`") && e.contains("step 9"), "{e}");
    }

    #[test]
    fn fill_does_not_rescan_inserted_text() {
        let t = "a{{X}}b{{Y}}c{{Z}}";
        assert_eq!(fill(t, &[("X", "{{Y}}"), ("Y", "2")]), "a{{Y}}b2c{{Z}}");
    }

    #[test]
    fn page_embeds_escaped_data() {
        let sc = Scenario::prototype();
        let d = view_data(
            &plan(),
            Path::new("p.csv"),
            &sc,
            &ViewOptions {
                title: Some("</script><b>&".into()),
                ..Default::default()
            },
        )
        .unwrap();
        let html = render_html(&d).unwrap();
        let json = extract_data_json(&html).unwrap();
        let v: serde_json::Value = serde_json::from_str(json).unwrap();
        assert_eq!(v["title"], "</script><b>&");
        assert_eq!(v["steps"].as_array().unwrap().len(), 4);
        assert!(!html.contains("{{DATA}}") && !html.contains("{{SCRIPT}}"));
        assert!(!SCRIPT.contains("</script") && !STYLE.contains("</style"));
    }
}
