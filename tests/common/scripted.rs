//! A scripted plant for the closed loop on pseudo-terminals (`tests/rig/relay_closed_loop.rs`,
//! `tests/rig/sensor_mount.rs`): the controller run offline through the library's own loop
//! (`planning::closed_loop::drive`) on a plant that reports what the controller predicts, which
//! gives the script of what is switched and reported; and the far ends' ball, which follows
//! that script as the LCUS boards' far ends switch its coils.
#![allow(dead_code)]

use super::relay_support::GUARD;
use serialport::{SerialPort, TTYPort};
use spherestep::commands::closed_replay::ClosedInputs;
use spherestep::model::geometry::{rot_q, Orientation, Radians, UnitVec};
use spherestep::planning::closed_loop::{drive, Controller, Decide, Decision, Ending, Plant};
use spherestep::planning::plan::PlanRow;
use spherestep::sensor::frame::Frame;
use spherestep::sensor::quat_csv::parse_line;
use std::collections::BTreeSet;
use std::io::Read;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The coils on, the orientation the plant reports while they are on.
pub type Script = Vec<(BTreeSet<usize>, Orientation)>;

/// A reading as the quat-csv far end prints it (shortest round trip).
pub fn line_of(q: &Orientation) -> String {
    format!("{},{},{},{}", q.w, q.i, q.j, q.k)
}

/// What a quat-csv far end does next ([`quat_csv_end`]).
pub enum Next {
    /// Print this line (a reading, or garbage).
    Line(String),
    /// Print nothing this time.
    Skip,
    /// Close its end.
    Close,
}

/// A quat-csv far end: every 10 ms, what `next` says, until `done` (or [`GUARD`]), or until its
/// port cannot be written.
pub fn quat_csv_end(
    mut port: TTYPort,
    done: Arc<AtomicBool>,
    mut next: impl FnMut() -> Next + Send + 'static,
) -> JoinHandle<()> {
    use std::io::Write;
    std::thread::spawn(move || {
        let start = Instant::now();
        while !done.load(Ordering::SeqCst) && start.elapsed() < GUARD {
            match next() {
                Next::Close => return,
                Next::Skip => {}
                Next::Line(line) => {
                    if port.write_all(format!("{line}\r\n").as_bytes()).is_err() {
                        return;
                    }
                }
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    })
}

/// The plant the controller runs on offline: each row switched reports the row's predicted
/// orientation (as the replay decodes it from a printed line), turned 4 degrees about X after
/// step `stray`; the script of what was switched and reported.
struct Scripted {
    stray: Option<usize>,
    script: Script,
}

impl Plant for Scripted {
    type Error = std::convert::Infallible;

    fn step(
        &mut self,
        step: usize,
        row: &PlanRow,
        decide: &mut Decide<'_>,
    ) -> Result<(Orientation, Decision), Self::Error> {
        assert_eq!(step, self.script.len());
        let mut q = row.q;
        if self.stray == Some(step) {
            let x = UnitVec::new_normalize(nalgebra::Vector3::x());
            q = rot_q(&x, Radians(4f64.to_radians())) * q;
        }
        // what the replay decodes from the printed line
        let q = parse_line(&line_of(&q)).unwrap();
        self.script
            .push((row.active.iter().map(|p| p.coil.0).collect(), q));
        assert!(self.script.len() < 200, "the offline loop does not end");
        Ok((q, decide(&q)))
    }

    fn replanned(&mut self, _step: usize, _ctl: &Controller) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// The controller of `inputs` run offline (the library's `drive`) on what the plant will
/// report: after the plan's row `stray` the measurement turned 4 degrees about X (no stray:
/// `None`). The script of what is switched and reported, and the replans; the loop must reach
/// the goal.
pub fn offline(inputs: &ClosedInputs, stray: Option<usize>) -> (Script, usize) {
    let motor = inputs.scenario.motor();
    let mut ctl = Controller::new(
        &motor,
        &inputs.settings,
        &inputs.open,
        inputs.goal,
        inputs.cl,
    )
    .unwrap();
    let mut plant = Scripted {
        stray,
        script: Script::new(),
    };
    let Ok((ending, _)) = drive(&mut ctl, &mut plant);
    match ending {
        Ending::Done => (plant.script, ctl.replans()),
        other => panic!("offline: {other:?}"),
    }
}

/// What the far ends share: the script, the coils on (both boards), how far the script went.
pub struct Ball {
    pub script: Script,
    /// Where the ball rests before anything is switched (the plan's start: the tare reads it).
    pub rest: Orientation,
    pub on: BTreeSet<usize>,
    /// The script entry whose coils were switched last.
    pub at: Option<usize>,
    /// What the sensor reports for the ball at q: `W * q * M` (none: q itself).
    pub frame: Option<Frame>,
}

impl Ball {
    /// The ball following `script` from rest at `rest`, read by a sensor in `frame`.
    pub fn shared(script: Script, rest: Orientation, frame: Option<Frame>) -> Shared {
        Arc::new(Mutex::new(Ball {
            script,
            rest,
            on: BTreeSet::new(),
            at: None,
            frame,
        }))
    }

    /// The orientation the ball has now (at rest at the plan's start before anything).
    pub fn now(&self) -> Orientation {
        self.at.map_or(self.rest, |k| self.script[k].1)
    }

    /// What the sensor reads now.
    pub fn sensed(&self) -> Orientation {
        match &self.frame {
            Some(f) => f.sensor(&self.now()),
            None => self.now(),
        }
    }

    /// Coil `coil` switched: advance to the next entry when its coils are the ones on.
    pub fn switch(&mut self, coil: usize, on: bool) {
        if on {
            self.on.insert(coil);
        } else {
            self.on.remove(&coil);
        }
        let next = self.at.map_or(0, |k| k + 1);
        if self.script.get(next).is_some_and(|(c, _)| *c == self.on) {
            self.at = Some(next);
        }
    }
}

pub type Shared = Arc<Mutex<Ball>>;

/// What a board's far end received: the bytes, and when each complete frame had arrived.
pub type Received = (Vec<u8>, Vec<Instant>);

/// An LCUS board's far end (coils `8 * index` on): records every byte (and when each frame
/// was complete) and tells the ball what it switched, until `done`.
pub fn board(
    mut port: TTYPort,
    index: usize,
    ball: Shared,
    done: Arc<AtomicBool>,
) -> JoinHandle<Received> {
    std::thread::spawn(move || {
        port.set_timeout(Duration::from_millis(5)).unwrap();
        let (mut got, mut buf, start) = (Vec::new(), [0u8; 64], Instant::now());
        let mut times = Vec::new();
        loop {
            assert!(start.elapsed() < GUARD, "board {index} never told to stop");
            match port.read(&mut buf) {
                Ok(n) => {
                    let at = Instant::now();
                    let old = got.len() / 4;
                    got.extend_from_slice(&buf[..n]);
                    let mut p = ball.lock().unwrap();
                    for f in got.chunks_exact(4).skip(old) {
                        assert_eq!(f[0], 0xA0, "board {index}: {got:02X?}");
                        p.switch(index * 8 + usize::from(f[1]) - 1, f[2] == 1);
                        times.push(at);
                    }
                }
                Err(_) if done.load(Ordering::SeqCst) => return (got, times),
                Err(_) => {}
            }
        }
    })
}
