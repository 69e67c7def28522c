//! `spherestep virtual`: a virtual motor on pseudo-terminals (relay boards and a sensor) for a
//! replay to drive; prints the ports, then the summary when the replay is done or on Ctrl-C.

use anyhow::{bail, Context, Result};
use spherestep::commands::rehearse::{self, VirtualOptions};
use spherestep::sensor::SensorFormat;
use std::io::Write;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// The arguments of `spherestep virtual`.
#[derive(clap::Args)]
pub struct Args {
    /// The plant: a scenario file (its physics, [relay] boards, coil map and limits).
    pub plant: PathBuf,
    /// One board of this protocol (lcus, kmtronic, numato, modbus) instead of relay.board.
    #[arg(long)]
    pub board: Option<spherestep::relay::BoardKind>,
    /// Also a sensor's pseudo-terminal: quat-csv (lines w,x,y,z at 50 Hz) or bno055 (UART).
    #[arg(long)]
    pub sensor: Option<SensorFormat>,
    /// The sensor's noise, degrees (0 to 10; seeded).
    #[arg(long, default_value_t = 0.0)]
    pub sensor_noise_deg: f64,
    /// Seed of the sensor's noise and of --sensor-garble.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The virtual clock runs this many times as fast as the wall clock (the limits are
    /// watched on it: replay with dwells this many times shorter).
    #[arg(long, default_value_t = 1.0)]
    pub speed: f64,
    /// The sensor's mounting on the ball, qx,qy,qz,qw: it reports the ball's orientation
    /// times this.
    #[arg(long)]
    pub mount: Option<String>,
    /// Make stable names for the ports: DIR/board0, DIR/board1, ..., DIR/sensor.
    #[arg(long)]
    pub link_dir: Option<PathBuf>,
    /// Write a CSV of every frame and event: t_s,port,frame,what,coils_on,qx,qy,qz,qw
    /// (the ball, in the summary's order; the sensor sends w,x,y,z, as the device).
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
    /// The plan being replayed: its pairs say which magnet each coil pulls (pair
    /// interaction) and the ball starts at its row 0 (else at plan.start).
    #[arg(long)]
    pub plan: Option<PathBuf>,
    /// The board that --drop-after-frames and --silent-after-frames act on (default 0).
    #[arg(long, default_value_t = 0)]
    pub fault_board: usize,
    /// Fault: the board's port vanishes after this many frames (its relays lose power).
    #[arg(long)]
    pub drop_after_frames: Option<usize>,
    /// Fault: the board stops answering after this many frames, its port open (it drops what
    /// it is sent; its relays hold).
    #[arg(long)]
    pub silent_after_frames: Option<usize>,
    /// Fault: the sensor goes silent after this many readings.
    #[arg(long)]
    pub sensor_stall_after: Option<usize>,
    /// Fault: this fraction (0 to 1) of the sensor's readings are corrupted.
    #[arg(long, default_value_t = 0.0)]
    pub sensor_garble: f64,
    /// Fault: this relay never closes (CH on board 0, or BOARD:CH).
    #[arg(long)]
    pub stuck_relay: Option<String>,
    /// Stop after this many seconds (wall clock) whatever happens.
    #[arg(long)]
    pub max_seconds: Option<f64>,
}

impl Args {
    fn options(&self) -> VirtualOptions {
        VirtualOptions {
            board: self.board,
            sensor: self.sensor,
            sensor_noise_deg: self.sensor_noise_deg,
            seed: self.seed,
            speed: self.speed,
            mount: self.mount.clone(),
            link_dir: self.link_dir.clone(),
            log: self.log.clone(),
            plan: self.plan.clone(),
            fault_board: self.fault_board,
            drop_after_frames: self.drop_after_frames,
            silent_after_frames: self.silent_after_frames,
            sensor_stall_after: self.sensor_stall_after,
            sensor_garble: self.sensor_garble,
            stuck_relay: self.stuck_relay.clone(),
            max_seconds: self.max_seconds,
            ..VirtualOptions::new(&self.plant)
        }
    }

    pub fn run(self, out: &mut dyn Write) -> Result<()> {
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst))
            .context("installing the Ctrl-C/SIGTERM handler")?;
        let o = self.options();
        let mut printed = Ok(());
        let summary = rehearse::run(&o, stop, &mut |ports| {
            let mut text = String::new();
            let (mut board_args, mut sensor_arg) = (Vec::new(), None);
            for p in ports {
                let name = p
                    .link
                    .as_ref()
                    .map_or(p.path.clone(), |l| l.display().to_string());
                text.push_str(&format!("{}: {}", p.what, p.path));
                if let Some(l) = &p.link {
                    text.push_str(&format!(" (link {})", l.display()));
                }
                text.push('\n');
                if p.what.starts_with("sensor") {
                    sensor_arg = Some(name);
                } else {
                    board_args.push(format!("--port {name}"));
                }
            }
            let sensor = match (sensor_arg, o.sensor) {
                (Some(s), Some(f)) => format!(" --sensor {s} --sensor-format {f}"),
                _ => String::new(),
            };
            let board = o.board.map(|b| format!(" --board {b}")).unwrap_or_default();
            // the plan being rehearsed, when it was given; else the user's own
            let plan = o
                .plan
                .as_ref()
                .map_or("PLAN.csv".to_string(), |p| p.display().to_string());
            text.push_str(&format!(
                "ready: in another terminal, spherestep replay {plan} {}{board} {}{sensor}\n",
                o.plant.display(),
                board_args.join(" ")
            ));
            printed = out.write_all(text.as_bytes()).and_then(|_| out.flush());
        })?;
        printed.context("writing the ports")?;
        if self.json {
            let j = serde_json::to_string_pretty(&summary).context("writing the summary")?;
            writeln!(out, "{j}")?;
        } else {
            write!(out, "{}", summary.text())?;
        }
        if summary.violations_total > 0 {
            bail!(
                "the virtual motor saw {} violation(s) of the hardware limits or protocols (listed above)",
                summary.violations_total
            );
        }
        Ok(())
    }
}
