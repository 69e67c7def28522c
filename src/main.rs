//! The spherestep command line: parses arguments and calls the library; errors are carried as
//! values to one place that prints them.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use spherestep::app;
use spherestep::scenario::{parse_orientation, Scenario};
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "spherestep", version, about = "Commutation, planning, settling and relay replay for spherical stepper motors")]
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
        } => {
            let sc = Scenario::load(&scenario)?;
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
        Command::Plot {
            csv,
            out: dir,
            title,
        } => {
            for f in spherestep::plots::plot_csv(&csv, dir.as_deref(), title.as_deref())? {
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
