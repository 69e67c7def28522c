//! `spherestep plan`: plans which coils to switch, in which order, to turn the ball about an
//! axis; the plan CSV and a summary.

use super::CsvOutput;
use anyhow::Result;
use spherestep::commands::args::check_out;
use spherestep::commands::{self as app, excite, waypoints};
use spherestep::io::scenario::Scenario;
use spherestep::model::geometry::Degrees;
use spherestep::planning::waypoints::DEFAULT_WAYPOINT_TOLERANCE_DEG;
use std::io::Write;
use std::path::PathBuf;

/// What to plan: the options `plan` and `run` share, each overriding the scenario's `[plan]`.
#[derive(clap::Args)]
pub struct PlanArgs {
    /// Desired rotation axis x,y,z (world frame).
    #[arg(long, allow_hyphen_values = true)]
    pub axis: Option<String>,
    /// Target rotation angle, degrees.
    #[arg(long)]
    pub angle: Option<f64>,
    /// min-axis-error, max-angle, weighted (the paper's) or search.
    #[arg(long)]
    pub scheme: Option<String>,
    /// Step model: pivot (paper 3.2), dynamic (paper 3.4) or coils (coil sets, every coil
    /// pulling what the physics says). Default: the scenario's `[plan] model`, else dynamic
    /// where the pair model describes the physics and coils where it does not.
    #[arg(long)]
    pub model: Option<String>,
    /// Pairs on after each step: K, or 2-K to choose per step (dynamic model: up to 8;
    /// default 2-4 for the dynamic model, 2 for the pivot model); coils on for the coil-set
    /// model (default 2-4).
    #[arg(long)]
    pub pairs: Option<String>,
    /// Start orientation qx,qy,qz,qw (default: the scenario's, else identity).
    #[arg(long, allow_hyphen_values = true)]
    pub from: Option<String>,
    /// Target orientation qx,qy,qz,qw instead of --axis and --angle: the rotation from the
    /// start to it (the shortest, at most 180 degrees) gives the axis and the angle.
    #[arg(long, allow_hyphen_values = true, conflicts_with_all = ["axis", "angle"])]
    pub to: Option<String>,
}

impl PlanArgs {
    /// The overrides of the scenario's plan settings.
    pub fn overrides(self) -> app::PlanOverrides {
        app::PlanOverrides {
            axis: self.axis,
            angle_deg: self.angle,
            scheme: self.scheme,
            model: self.model,
            pairs: self.pairs,
            from: self.from,
            to: self.to,
        }
    }
}

/// The arguments of `spherestep plan`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML); its [plan] section gives defaults for the options below.
    pub scenario: PathBuf,
    #[command(flatten)]
    pub what: PlanArgs,
    /// A CSV of waypoints to visit in order, as one motion, instead of --axis and --angle (or
    /// --to): orientations (columns qx,qy,qz,qw) or turns, each from the waypoint before, the
    /// first from the start (columns axis_x,axis_y,axis_z,angle_deg). The plan's rows say
    /// which waypoint each step serves.
    #[arg(long, conflicts_with_all = ["axis", "angle", "to"])]
    pub waypoints: Option<PathBuf>,
    /// The plan is reached when it ends within this many degrees of the target orientation
    /// (default: the scenario's plan.tolerance_deg, 1); with --waypoints, when it passes every
    /// waypoint within this many degrees (default 3).
    #[arg(long)]
    pub tolerance_deg: Option<f64>,
    /// An excitation run instead of a motion: the first set and N steps, each a random set
    /// of 2-3 coils switched on where the set before left the ball, within the supply and the
    /// on-time limit; replay it with a sensor and --log, then `fit --log` the log.
    #[arg(long, value_name = "N", conflicts_with_all = ["axis", "angle", "to", "waypoints", "tolerance_deg"])]
    pub excite: Option<usize>,
    /// The seed the excitation run's sets are drawn from (the same seed, the same run).
    #[arg(long, requires = "excite", default_value_t = 1)]
    pub seed: u64,
    #[command(flatten)]
    pub output: CsvOutput,
}

impl Args {
    pub fn run(self, out: &mut dyn Write) -> Result<()> {
        let Args {
            scenario,
            what,
            waypoints,
            tolerance_deg,
            excite,
            seed,
            output: CsvOutput {
                out: out_file,
                json,
            },
        } = self;
        let sc = Scenario::load(&scenario)?;
        if let Some(o) = &out_file {
            let read: Vec<PathBuf> = sc.files.iter().cloned().chain(waypoints.clone()).collect();
            check_out(o, &read)?;
        }
        let o = what.overrides();
        let mut settings = app::plan_settings(&sc, &o)?;
        let tolerance_deg = tolerance_deg.map(waypoints::check_tolerance).transpose()?;
        if let (Some(t), None) = (tolerance_deg, &waypoints) {
            settings.tolerance = Degrees(t).to_radians();
        }
        let (file, json) = (out_file.as_deref(), json);
        let mut note = std::io::stderr();
        if let Some(steps) = excite {
            let job = excite::ExciteJob {
                steps: excite::check_steps(steps)?,
                seed,
            };
            excite::excite_command(&sc, &settings, job, file, json, out, &mut note)?;
            return Ok(());
        }
        let (reached, message) = match &waypoints {
            Some(waypoints_file) => {
                let tolerance_deg = tolerance_deg.unwrap_or(DEFAULT_WAYPOINT_TOLERANCE_DEG);
                let job = waypoints::WaypointJob {
                    file: waypoints_file,
                    tolerance_deg,
                };
                let p = waypoints::plan_waypoints_command(
                    &sc, &settings, job, file, json, out, &mut note,
                )?;
                (p.reached, p.message)
            }
            None => {
                let p = app::plan_command(&sc, &settings, file, json, out, &mut note)?;
                (p.reached, p.message)
            }
        };
        if !reached {
            anyhow::bail!("{}", message.unwrap_or_else(|| "target not reached".into()));
        }
        Ok(())
    }
}
