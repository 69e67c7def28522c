//! The spherestep command line: parses arguments and calls the library; errors are carried as
//! values to one place that prints them.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use spherestep::commands::{self as app};
use spherestep::io::scenario::{parse_axis, parse_orientation, Scenario};
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "spherestep",
    version,
    about = "Commutation, planning, settling and relay replay for spherical stepper motors"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Report a scenario's packings: counts, separations, center lengths and their match.
    Packing {
        /// Scenario file (TOML).
        scenario: PathBuf,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Settle the ball under one active set (--pairs) or many (--sets FILE, in parallel).
    Settle {
        /// Scenario file (TOML).
        scenario: PathBuf,
        /// Active set: coil:magnet pairs, 0-based, e.g. 0:12,5:40.
        #[arg(long, conflicts_with = "sets", required_unless_present = "sets")]
        pairs: Option<String>,
        /// File with one active set per line; writes CSV, one row per line.
        #[arg(long)]
        sets: Option<PathBuf>,
        /// Start orientation qx,qy,qz,qw (default: identity).
        #[arg(long, allow_hyphen_values = true)]
        from: Option<String>,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
        /// Write the --sets CSV here instead of standard output.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Integrate with the reference path (ode_solvers' Dopri5, rtol 1e-10, atol 1e-12)
        /// instead of the scenario's [settle] method and tolerances.
        #[arg(long)]
        reference: bool,
    },
    /// Plan a motion: which coils to switch, in which order, to turn the ball about an axis.
    Plan {
        /// Scenario file (TOML); its [plan] section gives defaults for the options below.
        scenario: PathBuf,
        /// Desired rotation axis x,y,z (world frame).
        #[arg(long, allow_hyphen_values = true)]
        axis: Option<String>,
        /// Target rotation angle, degrees.
        #[arg(long)]
        angle: Option<f64>,
        /// min-axis-error, max-angle, weighted (the paper's) or search.
        #[arg(long)]
        scheme: Option<String>,
        /// Step model: pivot (paper 3.2) or dynamic (paper 3.4).
        #[arg(long)]
        model: Option<String>,
        /// Pairs on after each step: K, or 2-K to choose per step (dynamic model: up to 8;
        /// default 2-4 for the dynamic model, 2 for the pivot model).
        #[arg(long)]
        pairs: Option<String>,
        /// Start orientation qx,qy,qz,qw (default: the scenario's, else identity).
        #[arg(long, allow_hyphen_values = true)]
        from: Option<String>,
        /// Write the plan CSV here (else it goes alone to standard output, the summary to
        /// standard error).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Print a JSON summary.
        #[arg(long)]
        json: bool,
    },
    /// Replay a plan's coil sequence through the dynamic model and measure the "slop".
    Simulate {
        /// Plan CSV (from `plan --out`).
        plan: PathBuf,
        /// Scenario to simulate in (default: the built-in prototype).
        scenario: Option<PathBuf>,
        /// Write the per-step CSV here (else it goes alone to standard output, the summary to
        /// standard error).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Print a JSON summary.
        #[arg(long)]
        json: bool,
    },
    /// Run many scenarios (plans and sweeps) in parallel: one CSV each, plus summary.csv.
    Batch {
        /// Scenario files or folders of them.
        #[arg(required = true)]
        inputs: Vec<PathBuf>,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
        /// Worker threads (default: all cores). Output is the same for any number.
        #[arg(long)]
        jobs: Option<usize>,
        /// Run part I of N (0-based), e.g. 0/3; merge with a later run using --resume.
        #[arg(long)]
        shard: Option<String>,
        /// Skip scenarios whose output is up to date; merge finished shard parts.
        #[arg(long)]
        resume: bool,
        /// Also draw the pictures (Figures 5-8, sweep maps) and the 3-D page of each result.
        #[arg(long)]
        plots: bool,
    },
    /// Replay a plan on a relay board: switch each step's coils, wait, all off at the end
    /// (and on error or Ctrl-C). Settings come from the scenario's [relay] section or --map.
    Replay {
        /// Plan CSV (as written by `plan`).
        plan: PathBuf,
        /// Scenario file (TOML) with the coil count and [relay] settings (default: prototype).
        scenario: Option<PathBuf>,
        /// Serial device, e.g. /dev/ttyUSB0 (not needed with --dry-run).
        #[arg(long, required_unless_present = "dry_run")]
        port: Option<String>,
        /// Board protocol: lcus, kmtronic, numato or modbus (default: relay.board).
        #[arg(long)]
        board: Option<spherestep::relay::BoardKind>,
        /// Baud rate (default: relay.baud, else the vendor's).
        #[arg(long)]
        baud: Option<u32>,
        /// realtime (switch, wait the dwell) or step (wait for Enter; q quits).
        #[arg(long, default_value = "realtime")]
        mode: spherestep::relay::replay::Mode,
        /// Fixed dwell per step, ms (default: settle time x relay.dwell_factor, at least the floor).
        #[arg(long)]
        dwell_ms: Option<u64>,
        /// First step to replay (the step before is re-energised first to hold the ball).
        #[arg(long, default_value_t = 0)]
        from_step: usize,
        /// Print the frames and timing; open no port.
        #[arg(long)]
        dry_run: bool,
        /// Append a CSV of what was sent when (flushed per step).
        #[arg(long)]
        log: Option<PathBuf>,
        /// Read the relays back after each step; stop (all off) on a mismatch.
        #[arg(long)]
        verify: bool,
        /// TOML map file with the [relay] keys at the top (replaces the scenario's section).
        #[arg(long)]
        map: Option<PathBuf>,
    },
    /// Write one self-contained HTML page showing a plan in 3-D (opens from disk, no network).
    View {
        /// Plan file (CSV, as written by `plan`).
        plan: PathBuf,
        /// Scenario file (TOML) with the packings; default: the built-in prototype.
        scenario: Option<PathBuf>,
        /// The HTML page to write.
        #[arg(long)]
        out: PathBuf,
        /// Simulate results (CSV with columns step,qx,qy,qz,qw) to draw as a ghost ball.
        #[arg(long)]
        sim: Option<PathBuf>,
        /// Desired rotation axis x,y,z (default: the axis of the plan's total rotation).
        #[arg(long, allow_hyphen_values = true)]
        axis: Option<String>,
    },
    /// Draw an existing result CSV (plan or sweep, told by its header) as SVG and PNG.
    Plot {
        /// A plan CSV (axis error vs. rotation angle) or a sweep CSV (map of the worst axis error).
        csv: PathBuf,
        /// Folder for the pictures (default: next to the CSV).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Title of the figure (default: from the file name).
        #[arg(long)]
        title: Option<String>,
    },
    /// Regenerate the built-in prototype's coordinate files from their generators.
    Prototype {
        /// Folder to write rotor.csv and stator.csv into.
        #[arg(long, default_value = "scenarios/prototype")]
        out: PathBuf,
    },
}

fn run(cli: Cli) -> Result<()> {
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    match cli.command {
        Command::Packing { scenario, json } => {
            let sc = Scenario::load(&scenario)?;
            app::packing_report(&sc, json, &mut out)?;
        }
        Command::Settle {
            scenario,
            pairs,
            sets,
            from,
            json,
            out: out_file,
            reference,
        } => {
            let mut sc = Scenario::load(&scenario)?;
            if reference {
                sc.settle = sc.settle.reference();
            }
            let q0 = match from {
                Some(f) => parse_orientation(&f, "--from")?,
                None => nalgebra::UnitQuaternion::identity(),
            };
            if let Some(sets) = sets {
                let list = app::read_sets(&sc, &sets)?;
                match out_file {
                    Some(path) => {
                        let mut buf = Vec::new();
                        app::settle_sets(&sc, &list, &q0, &mut buf)?;
                        std::fs::write(&path, buf)
                            .with_context(|| format!("writing {}", path.display()))?;
                    }
                    None => {
                        app::settle_sets(&sc, &list, &q0, &mut out)?;
                    }
                }
            } else if let Some(pairs) = pairs {
                app::settle_one(&sc, &pairs, &q0, json, &mut out)?;
            }
        }
        Command::Plan {
            scenario,
            axis,
            angle,
            scheme,
            model,
            pairs,
            from,
            out: out_file,
            json,
        } => {
            let sc = Scenario::load(&scenario)?;
            let o = app::PlanOverrides {
                axis,
                angle_deg: angle,
                scheme,
                model,
                pairs,
                from,
            };
            let settings = app::plan_settings(&sc, &o)?;
            let p = app::plan_command(
                &sc,
                &settings,
                out_file.as_deref(),
                json,
                &mut out,
                &mut std::io::stderr(),
            )?;
            if !p.reached {
                anyhow::bail!(
                    "{}",
                    p.message.unwrap_or_else(|| "target not reached".into())
                );
            }
        }
        Command::Simulate {
            plan,
            scenario,
            out: out_file,
            json,
        } => {
            let sc = match scenario {
                Some(p) => Scenario::load(&p)?,
                None => Scenario::prototype(),
            };
            let sim = app::simulate_plan(&sc, &plan)?;
            let mut buf = Vec::new();
            spherestep::planning::simulate::write_sim(&sim, &mut buf)?;
            // Without --out the CSV alone goes to standard output, the summary to standard error.
            let csv_on_stdout = out_file.is_none() && !json;
            match &out_file {
                Some(p) => spherestep::io::output::write_atomic(p, &buf)?,
                None if csv_on_stdout => out.write_all(&buf)?,
                None => {}
            }
            let s = spherestep::planning::simulate::summary(&sim);
            if json {
                writeln!(out, "{}", serde_json::to_string(&s)?)?;
            } else {
                let mut stderr = std::io::stderr();
                let note: &mut dyn Write = if csv_on_stdout { &mut stderr } else { &mut out };
                writeln!(
                    note,
                    "{} steps: max deviation {:.3} deg, final deviation {:.3} deg, {} unsettled",
                    s.steps, s.max_deviation_deg, s.final_deviation_deg, s.unsettled_steps
                )?;
            }
        }
        Command::Batch {
            inputs,
            out: out_dir,
            jobs,
            shard,
            resume,
            plots,
        } => {
            if jobs == Some(0) {
                anyhow::bail!("argument --jobs: expected a number of threads >= 1, got 0");
            }
            let opts = spherestep::commands::batch::BatchOptions {
                out: out_dir,
                jobs,
                shard: shard
                    .as_deref()
                    .map(spherestep::commands::batch::Shard::parse)
                    .transpose()?,
                resume,
                progress: true,
                plots,
            };
            let files = spherestep::commands::batch::collect_inputs(&inputs)?;
            let report = spherestep::commands::batch::run_batch(&files, &opts)?;
            writeln!(
                out,
                "{} computed, {} up to date, {} failed",
                report.ran.len(),
                report.skipped.len(),
                report.failed.len()
            )?;
            for (name, err) in &report.failed {
                eprintln!("spherestep: scenario {name} failed: {err}");
            }
            if !report.failed.is_empty() {
                anyhow::bail!("{} scenario(s) failed", report.failed.len());
            }
        }
        Command::Replay {
            plan,
            scenario,
            port,
            board,
            baud,
            mode,
            dwell_ms,
            from_step,
            dry_run,
            log,
            verify,
            map,
        } => {
            use spherestep::commands::replay::{self, ReplayOptions};
            use spherestep::relay::replay::{stdin_lines, Mode};
            use std::sync::{atomic::AtomicBool, atomic::Ordering, Arc};
            let stop = Arc::new(AtomicBool::new(false));
            let flag = stop.clone();
            ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst))
                .context("installing the Ctrl-C/SIGTERM handler")?;
            let opts = ReplayOptions {
                plan,
                scenario,
                map,
                port,
                board,
                baud,
                mode,
                dwell_ms,
                from_step,
                dry_run,
                log,
                verify,
            };
            let input = (mode == Mode::Step && !dry_run).then(stdin_lines);
            replay::run(&opts, stop, input, &mut out)?;
        }
        Command::View {
            plan,
            scenario,
            out: page,
            sim,
            axis,
        } => {
            let sc = match scenario {
                Some(p) => Scenario::load(&p)?,
                None => Scenario::prototype(),
            };
            let axis = axis.map(|a| parse_axis(&a, "--axis")).transpose()?;
            let data =
                spherestep::figures::view::write_view(&plan, &sc, sim.as_deref(), axis, &page)?;
            writeln!(out, "wrote {} ({} steps)", page.display(), data.steps.len())?;
        }
        Command::Plot {
            csv,
            out: dir,
            title,
        } => {
            for f in spherestep::figures::plots::plot_csv(&csv, dir.as_deref(), title.as_deref())? {
                writeln!(out, "wrote {}", f.display())?;
            }
        }
        Command::Prototype { out: dir } => {
            app::write_prototype(&dir)?;
            writeln!(out, "wrote {}/rotor.csv and stator.csv", dir.display())?;
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("spherestep: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
