//! What a front end brings to a scenario, checked in one place for every front end (the
//! command line's options, the Python arguments): changes to its `[plan]` settings (a refusal
//! names the change as the front end calls it, [`ChangeNames`]), and a plan's pairs, from a
//! file or an argument ([`RowsFrom`], [`PlanInput`]).

use super::{check_pairs_per_step, check_supply, default_pairs_per_step, Scenario};
use crate::error::{Error, Result};
use crate::io::planfile::read_plan;
use crate::model::geometry::{Orientation, UnitVec};
use crate::planning::commutation::{PairsPerStep, StepModel};
pub use crate::planning::options::RowsFrom;
use crate::planning::plan::{target_angle, turn_to, PlanRow};
use crate::planning::planner::{PlanSettings, Scheme};
use std::path::Path;

/// The changes asked for, each already read as its type by the front end (`None` keeps the
/// scenario's value); the scheme and the model by name, as a user gives them.
#[derive(Debug, Clone, Default)]
pub struct PlanChanges<'a> {
    /// The axis of rotation (world frame), for `plan.axis`.
    pub axis: Option<UnitVec>,
    /// The angle to turn (degrees), for `plan.angle_deg`.
    pub angle_deg: Option<f64>,
    /// The planner's name (`search`, `min-axis-error`, ...), for `plan.scheme`.
    pub scheme: Option<&'a str>,
    /// The step model's name (`pivot`, `dynamic` or `coils`), for `plan.model`; without
    /// `pairs`, the model's default pairs per step.
    pub model: Option<&'a str>,
    /// How many pairs a step switches on (the `K` or `2-K` of `plan.model`).
    pub pairs: Option<PairsPerStep>,
    /// The ball's orientation at the start (body to world), for `plan.start`.
    pub start: Option<Orientation>,
    /// A target orientation (instead of an axis and an angle).
    pub to: Option<Orientation>,
}

/// What a front end calls each change, for its refusals (`--from` on the command line, `start`
/// in Python).
#[derive(Debug, Clone, Copy)]
pub struct ChangeNames {
    /// The name of [`PlanChanges::axis`] (on the command line `--axis`).
    pub axis: &'static str,
    /// The name of [`PlanChanges::angle_deg`] (on the command line `--angle`).
    pub angle: &'static str,
    /// The name of [`PlanChanges::scheme`] (on the command line `--scheme`).
    pub scheme: &'static str,
    /// The name of [`PlanChanges::model`] (on the command line `--model`).
    pub model: &'static str,
    /// The name of [`PlanChanges::pairs`] (on the command line `--pairs`).
    pub pairs: &'static str,
    /// The name of [`PlanChanges::start`] (on the command line `--from`).
    pub start: &'static str,
    /// The name of [`PlanChanges::to`] (on the command line `--to`).
    pub to: &'static str,
}

/// A plan a front end gives to be played in a scenario: the path of a plan file, or rows it
/// holds (a plan made before) given as its argument `argument`.
#[derive(Debug, Clone)]
pub enum PlanInput<'a> {
    /// A plan CSV to read (`spherestep plan --out`'s format).
    File(&'a Path),
    /// Rows already in memory.
    Rows {
        /// The plan's rows, row 0 the start.
        rows: Vec<PlanRow>,
        /// The front end's name for the argument that held them, for refusals.
        argument: &'a str,
    },
}

impl Scenario {
    /// Checks the pairs of a plan's `rows` against the scenario it is played in: a refusal
    /// names where the rows came from and the scenario.
    pub fn check_plan_pairs(&self, rows: &[PlanRow], from: RowsFrom<'_>) -> Result<()> {
        for (k, r) in rows.iter().enumerate() {
            self.check_active(&r.active, "active").map_err(|e| {
                let message = format!("{e} (in scenario {})", self.path.display());
                match from {
                    RowsFrom::File(file) => Error::Row {
                        file: file.to_path_buf(),
                        line: k + 2,
                        message,
                    },
                    RowsFrom::Argument(name) => Error::Arg {
                        arg: format!("{name} (step {k})"),
                        expected: message,
                    },
                }
            })?;
        }
        Ok(())
    }

    /// The rows of the plan `input` (a plan file read, or the rows given), their pairs checked
    /// against the scenario ([`Scenario::check_plan_pairs`]).
    pub fn checked_rows(&self, input: PlanInput<'_>) -> Result<Vec<PlanRow>> {
        let (rows, from) = match input {
            PlanInput::File(file) => (read_plan(file)?, RowsFrom::File(file)),
            PlanInput::Rows { rows, argument } => (rows, RowsFrom::Argument(argument)),
        };
        self.check_plan_pairs(&rows, from)?;
        Ok(rows)
    }

    /// The scenario's `[plan]` settings with `changes` made, each checked as the scenario's own
    /// value is: a scheme or model by its name, the pairs per step against the model and the
    /// supply, a target orientation not with an axis or an angle. A refusal is
    /// [`Error::Arg`], naming the change by `names`.
    pub fn plan_with(
        &self,
        changes: &PlanChanges<'_>,
        names: &ChangeNames,
    ) -> Result<PlanSettings> {
        let arg = |name: &str, expected: String| Error::Arg {
            arg: name.into(),
            expected,
        };
        let mut s = self.plan.clone();
        if let Some(a) = changes.axis {
            s.axis = a;
        }
        if let Some(a) = changes.angle_deg {
            s.angle = target_angle(a, names.start).map_err(|e| arg(names.angle, e))?;
        }
        if let Some(n) = changes.scheme {
            s.scheme = Scheme::parse(n).map_err(|e| arg(names.scheme, e))?;
        }
        if let Some(m) = changes.model {
            s.model = StepModel::from_name(m)
                .ok_or_else(|| arg(names.model, format!("pivot, dynamic or coils, got '{m}'")))?;
            if changes.pairs.is_none() {
                s.pairs = default_pairs_per_step(s.model);
            }
        }
        if let Some(k) = changes.pairs {
            s.pairs = k;
        }
        check_pairs_per_step(s.model, s.pairs).map_err(|m| arg(names.pairs, m))?;
        check_supply(s.pairs, s.limits.max_coils_on)
            .map_err(|m| arg(names.pairs, format!("{m} (in {})", self.path.display())))?;
        if let Some(f) = changes.start {
            s.start = f;
        }
        if let Some(to) = changes.to {
            if changes.axis.is_some() || changes.angle_deg.is_some() {
                return Err(arg(
                    names.to,
                    "a target orientation or an axis and an angle, not both".into(),
                ));
            }
            (s.axis, s.angle) =
                turn_to(&s.start, &to, names.start).map_err(|e| arg(names.to, e))?;
            s.target = Some(to);
        }
        Ok(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::geometry::{rot_q, unit, Radians};
    use nalgebra::UnitQuaternion;
    use nalgebra::Vector3;

    const SHORT: ChangeNames = ChangeNames {
        axis: "a",
        angle: "b",
        scheme: "c",
        model: "d",
        pairs: "e",
        start: "f",
        to: "g",
    };

    /// The refusal's argument and message of `changes`.
    fn refused(changes: &PlanChanges<'_>) -> (String, String) {
        match Scenario::prototype().plan_with(changes, &SHORT) {
            Err(Error::Arg { arg, expected }) => (arg, expected),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn each_refusal_names_the_change_as_the_front_end_calls_it() {
        let (arg, e) = refused(&PlanChanges {
            scheme: Some("fastest"),
            ..Default::default()
        });
        assert_eq!(arg, "c", "{e}");
        let (arg, e) = refused(&PlanChanges {
            model: Some("springs"),
            ..Default::default()
        });
        assert_eq!(
            (arg.as_str(), e.as_str()),
            ("d", "pivot, dynamic or coils, got 'springs'")
        );
        let (arg, e) = refused(&PlanChanges {
            model: Some("pivot"),
            pairs: Some(PairsPerStep::exactly(3)),
            ..Default::default()
        });
        assert_eq!(arg, "e", "{e}");
        let (arg, e) = refused(&PlanChanges {
            pairs: Some(PairsPerStep::exactly(6)),
            ..Default::default()
        });
        assert!(
            arg == "e" && e.contains("<built-in prototype>"),
            "{arg}: {e}"
        );
        let to = rot_q(&unit(Vector3::new(0.0, 1.0, 0.0)).unwrap(), Radians(0.5));
        let (arg, e) = refused(&PlanChanges {
            angle_deg: Some(30.0),
            to: Some(to),
            ..Default::default()
        });
        assert_eq!(
            (arg.as_str(), e.as_str()),
            (
                "g",
                "a target orientation or an axis and an angle, not both"
            )
        );
        // the start's name in a message about another change
        let (arg, e) = refused(&PlanChanges {
            angle_deg: Some(200.0),
            ..Default::default()
        });
        assert!(arg == "b" && e.contains("each starting (f)"), "{arg}: {e}");
        let (arg, e) = refused(&PlanChanges {
            to: Some(UnitQuaternion::identity()),
            ..Default::default()
        });
        assert!(
            arg == "g" && e.contains("other than the start"),
            "{arg}: {e}"
        );
    }

    #[test]
    fn a_target_orientation_becomes_the_shortest_turn_from_the_start() {
        let start = rot_q(&unit(Vector3::new(1.0, 0.0, 0.0)).unwrap(), Radians(0.3));
        let turn = rot_q(&unit(Vector3::new(0.0, 0.6, 0.8)).unwrap(), Radians(1.2));
        let s = Scenario::prototype()
            .plan_with(
                &PlanChanges {
                    model: Some("coils"),
                    start: Some(start),
                    to: Some(turn * start),
                    ..Default::default()
                },
                &SHORT,
            )
            .unwrap();
        assert!((s.angle.0 - 1.2).abs() < 1e-12);
        assert!((s.axis.into_inner() - Vector3::new(0.0, 0.6, 0.8)).norm() < 1e-12);
        assert_eq!(s.model, StepModel::Coils);
        assert_eq!(s.pairs, default_pairs_per_step(StepModel::Coils));
        assert_eq!(s.target, Some(turn * start));
    }

    #[test]
    fn a_plans_pair_the_scenario_lacks_is_refused_where_the_rows_came_from() {
        use crate::model::geometry::{CoilId, MagnetId, Pair};
        let row = |step: usize, coil: usize| PlanRow {
            step,
            pivot: None,
            new: Vec::new(),
            active: vec![Pair {
                coil: CoilId(coil),
                magnet: MagnetId(3),
            }],
            q: UnitQuaternion::identity(),
            step_angle_deg: 0.0,
            step_axis_error_deg: 0.0,
            cum_angle_deg: 0.0,
            cum_axis_error_deg: 0.0,
            settle_time_s: 0.0,
            settled: true,
        };
        let sc = Scenario::prototype();
        let rows = [row(0, 1), row(1, 99)];
        let file = Path::new("p.csv");
        match sc.check_plan_pairs(&rows, RowsFrom::File(file)) {
            Err(Error::Row {
                file,
                line,
                message,
            }) => {
                assert_eq!((file.as_path(), line), (Path::new("p.csv"), 3));
                assert!(
                    message.contains("(in scenario <built-in prototype>)"),
                    "{message}"
                );
            }
            other => panic!("{other:?}"),
        }
        match sc.check_plan_pairs(&rows, RowsFrom::Argument("plan")) {
            Err(Error::Arg { arg, .. }) => assert_eq!(arg, "plan (step 1)"),
            other => panic!("{other:?}"),
        }
        assert!(sc
            .check_plan_pairs(&rows[..1], RowsFrom::Argument("plan"))
            .is_ok());
    }
}
