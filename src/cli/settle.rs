//! `spherestep settle`: settles the ball under one active set or under many, in parallel.

use anyhow::Result;
use spherestep::commands::args::{check_out, parse_orientation};
use spherestep::commands::{self as app};
use spherestep::io::output::write_atomic;
use spherestep::io::scenario::Scenario;
use std::io::Write;
use std::path::PathBuf;

/// The arguments of `spherestep settle`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML).
    pub scenario: PathBuf,
    /// Active set: coil:magnet pairs, 0-based, e.g. 0:12,5:40.
    #[arg(long, conflicts_with = "sets", required_unless_present = "sets")]
    pub pairs: Option<String>,
    /// File with one active set per line; writes CSV, one row per line.
    #[arg(long)]
    pub sets: Option<PathBuf>,
    /// Start orientation qx,qy,qz,qw (default: identity).
    #[arg(long, allow_hyphen_values = true)]
    pub from: Option<String>,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Write the --sets CSV here instead of standard output.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Integrate with the reference path (ode_solvers' Dopri5, rtol 1e-10, atol 1e-12)
    /// instead of the scenario's [settle] method and tolerances.
    #[arg(long)]
    pub reference: bool,
}

impl Args {
    pub fn run(self, out: &mut dyn Write) -> Result<()> {
        let Args {
            scenario,
            pairs,
            sets,
            from,
            json,
            out: out_file,
            reference,
        } = self;
        let mut sc = Scenario::load(&scenario)?;
        if let Some(o) = &out_file {
            let mut read = sc.files.clone();
            read.extend(sets.clone());
            check_out(o, &read)?;
        }
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
                    write_atomic(&path, &buf)?;
                }
                None => {
                    app::settle_sets(&sc, &list, &q0, out)?;
                }
            }
        } else if let Some(pairs) = pairs {
            app::settle_one(&sc, &pairs, &q0, json, out)?;
        }
        Ok(())
    }
}
