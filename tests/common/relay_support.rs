//! Shared pieces of the relay tests: plan and scenario fixtures, a pseudo-terminal pair, and
//! threads that play each relay board on the far end of it.
#![allow(dead_code)]

use serialport::{SerialPort, TTYPort};
use spherestep::commands::replay::{self, ReplayOptions};
use spherestep::commands::{plan_settings, PlanOverrides};
use spherestep::io::planfile::write_plan;
use spherestep::io::scenario::Scenario;
use spherestep::planning::planner;
use spherestep::relay::modbus::crc16;
use spherestep::relay::replay::{execute, execute_on, Summary};
use spherestep::relay::{Link, RelayError};
use spherestep::Error;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::mpsc::Receiver;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Longest any board end waits for bytes before giving up (a guard against hangs, not a
/// timing assertion).
pub const GUARD: Duration = Duration::from_secs(30);

/// Writes a plan with the given active sets (`coil:magnet;...`), one row per step.
pub fn plan(dir: &Path, name: &str, steps: &[&str], settle_s: f64) -> PathBuf {
    let mut text = String::from(
        "step,pivot_coil,pivot_magnet,new_coil,new_magnet,active,qx,qy,qz,qw,step_angle_deg,step_axis_error_deg,cum_angle_deg,cum_axis_error_deg,settle_time_s\n",
    );
    for (k, active) in steps.iter().enumerate() {
        // pivot/new are informative only: `active` is authoritative for the replay.
        text.push_str(&format!("{k},,,,,{active},0,0,0,1,0,0,0,0,{settle_s}\n"));
    }
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// The three-step plan most tests replay: coils {0,1}, then {0,2}, then {2,3}.
pub fn short_plan(dir: &Path) -> PathBuf {
    plan(
        dir,
        "plan.csv",
        &["0:10;1:11", "0:10;2:12", "2:12;3:13"],
        0.1,
    )
}

/// Writes a scenario (the prototype) with the given `[relay]` section body.
pub fn scenario(dir: &Path, relay: &str) -> PathBuf {
    let p = dir.join("scenario.toml");
    std::fs::write(&p, format!("name = \"relay test\"\n[relay]\n{relay}\n")).unwrap();
    p
}

/// A pseudo-terminal pair: (board end, computer end).
pub fn pty() -> (TTYPort, TTYPort) {
    TTYPort::pair().expect("a pseudo-terminal pair")
}

/// The computer end as a replay link: a second descriptor of it, so that the pseudo-terminal
/// stays open (the caller keeps `slave`) while the board end reads what is left after the
/// replay dropped its link.
pub fn link(slave: &TTYPort) -> Link {
    let port = slave
        .try_clone_native()
        .expect("a second descriptor of the pty");
    Link::from_port(Box::new(port), "pty", Duration::from_secs(5))
}

/// The computer end as a replay link named by its device path, as an opened port is named
/// (see `link`).
pub fn named_link(slave: &TTYPort) -> Link {
    let port = slave
        .try_clone_native()
        .expect("a second descriptor of the pty");
    Link::from_port(Box::new(port), &path_of(slave), Duration::from_secs(5))
}

/// Options for an in-process replay with no dwell (no timing involved).
pub fn options(plan: &Path, scenario: &Path) -> ReplayOptions {
    let mut o = ReplayOptions::new(plan);
    o.scenario = Some(scenario.to_path_buf());
    o.dwell_ms = Some(0);
    o
}

/// Prepares and runs a replay over `link`, printing into a buffer.
pub fn run(opts: &ReplayOptions, link: Link) -> (Result<Summary, Error>, String) {
    let mut out = Vec::new();
    let r = replay::prepare(opts).and_then(|prep| {
        execute(
            &prep,
            link,
            Arc::new(AtomicBool::new(false)),
            None,
            &mut out,
        )
        .map_err(Error::from)
    });
    (r, String::from_utf8_lossy(&out).into_owned())
}

/// Prepares and runs a replay over `links`, one per board in order, printing into a buffer;
/// `input` feeds step mode.
pub fn run_on(
    opts: &ReplayOptions,
    links: Vec<Link>,
    input: Option<Receiver<String>>,
) -> (Result<Summary, Error>, String) {
    let mut out = Vec::new();
    let r = replay::prepare(opts).and_then(|prep| {
        execute_on(
            &prep,
            links,
            Arc::new(AtomicBool::new(false)),
            input,
            &mut out,
        )
        .map_err(Error::from)
    });
    (r, String::from_utf8_lossy(&out).into_owned())
}

/// The frames switching channels 1..=n of an LCUS board off, as one byte string (its all-off).
pub fn lcus_all_off(n: u8) -> Vec<u8> {
    let all = [
        0xA0, 0x01, 0x00, 0xA1, 0xA0, 0x02, 0x00, 0xA2, 0xA0, 0x03, 0x00, 0xA3, 0xA0, 0x04, 0x00,
        0xA4, 0xA0, 0x05, 0x00, 0xA5, 0xA0, 0x06, 0x00, 0xA6, 0xA0, 0x07, 0x00, 0xA7, 0xA0, 0x08,
        0x00, 0xA8,
    ];
    all[..4 * usize::from(n)].to_vec()
}

/// The listing rows of a replay's output without their time column (the first 10 characters),
/// from the first row after the column heads.
pub fn rows_without_time(text: &str) -> Vec<String> {
    text.lines()
        .skip_while(|l| !l.trim_start().starts_with("t_s"))
        .skip(1)
        .filter(|l| !l.starts_with("--") && l.len() > 10 && l.as_bytes()[9] == b' ')
        .map(|l| l[10..].to_string())
        .collect()
}

/// Reads exactly `n` bytes from the board end (panics after `GUARD`).
pub fn read_n(port: &mut TTYPort, n: usize) -> Vec<u8> {
    let deadline = Instant::now() + GUARD;
    let mut got = Vec::new();
    let mut buf = [0u8; 256];
    while got.len() < n {
        assert!(Instant::now() < deadline, "board end got only {got:02X?}");
        let want = (n - got.len()).min(buf.len());
        match port.read(&mut buf[..want]) {
            Ok(k) => got.extend_from_slice(&buf[..k]),
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
            Err(e) => panic!("board end read failed: {e}"),
        }
    }
    got
}

/// Whatever is still waiting at the board end (after the replay returned).
pub fn leftover(port: &mut TTYPort) -> Vec<u8> {
    port.set_timeout(Duration::from_millis(50)).unwrap();
    let mut got = Vec::new();
    let mut buf = [0u8; 256];
    while let Ok(k) = port.read(&mut buf) {
        if k == 0 {
            break;
        }
        got.extend_from_slice(&buf[..k]);
    }
    got
}

/// A board that only listens (LCUS, KMTronic): collects `n` bytes.
pub fn listen(mut port: TTYPort, n: usize) -> JoinHandle<(Vec<u8>, TTYPort)> {
    std::thread::spawn(move || {
        let got = read_n(&mut port, n);
        (got, port)
    })
}

/// What a fake Modbus slave does with request number `k` (0-based).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Act {
    Answer,
    /// Answer a read with this coil mask instead of the truth.
    Lie(u16),
    /// Close the port without answering.
    Close,
}

/// A Modbus RTU slave (address 1, up to 16 coils) handling `n` requests; `act(k)` says what
/// to do with request k. Returns the requests received.
pub fn modbus_slave(
    mut port: TTYPort,
    n: usize,
    act: impl Fn(usize) -> Act + Send + 'static,
) -> JoinHandle<(Vec<Vec<u8>>, Option<TTYPort>)> {
    std::thread::spawn(move || {
        let mut coils: u16 = 0;
        let mut frames = Vec::new();
        for k in 0..n {
            let mut req = read_n(&mut port, 2);
            match req[1] {
                0x05 | 0x01 => req.extend(read_n(&mut port, 6)),
                0x0F => {
                    req.extend(read_n(&mut port, 5));
                    let count = req[6] as usize;
                    req.extend(read_n(&mut port, count + 2));
                }
                f => panic!("unexpected function {f:02X}"),
            }
            frames.push(req.clone());
            let what = act(k);
            if what == Act::Close {
                drop(port);
                return (frames, None);
            }
            let reply = match req[1] {
                0x05 => {
                    let bit = 1u16 << u16::from_be_bytes([req[2], req[3]]);
                    if req[4] == 0xFF {
                        coils |= bit
                    } else {
                        coils &= !bit
                    }
                    req.clone()
                }
                0x0F => {
                    coils = u16::from_le_bytes([req[7], *req.get(8).unwrap_or(&0)]);
                    req[..6].to_vec()
                }
                _ => {
                    let shown = match what {
                        Act::Lie(m) => m,
                        _ => coils,
                    };
                    let mut r = vec![0x01, 0x01, 0x02];
                    r.extend(shown.to_le_bytes());
                    r
                }
            };
            let mut reply = reply;
            if req[1] != 0x05 {
                let c = crc16(&reply);
                reply.extend(c);
            }
            port.write_all(&reply).unwrap();
        }
        (frames, Some(port))
    })
}

/// A Numato module (16 relays) handling `n` commands: echoes, answers reads, prompts `>`.
pub fn numato_module(mut port: TTYPort, n: usize) -> JoinHandle<(Vec<String>, TTYPort)> {
    std::thread::spawn(move || {
        let mut relays: u32 = 0;
        let mut cmds = Vec::new();
        for _ in 0..n {
            let mut cmd = Vec::new();
            while cmd.last() != Some(&b'\r') {
                cmd.extend(read_n(&mut port, 1));
            }
            let text = String::from_utf8(cmd).unwrap();
            let words: Vec<&str> = text.trim_end().split(' ').collect();
            let index = |w: &str| -> u32 {
                let c = w.as_bytes()[0];
                if c.is_ascii_digit() {
                    u32::from(c - b'0')
                } else {
                    u32::from(c - b'A') + 10
                }
            };
            let answer = match words.as_slice() {
                ["relay", "on", r] => {
                    relays |= 1 << index(r);
                    None
                }
                ["relay", "off", r] => {
                    relays &= !(1 << index(r));
                    None
                }
                ["relay", "writeall", m] => {
                    relays = u32::from_str_radix(m, 16).unwrap();
                    None
                }
                ["relay", "readall"] => Some(format!("{relays:04x}")),
                other => panic!("unexpected command {other:?}"),
            };
            let mut reply = format!("{}\n\r", text.trim_end_matches('\r'));
            if let Some(a) = answer {
                reply.push_str(&a);
                reply.push_str("\n\r");
            }
            reply.push('>');
            port.write_all(reply.as_bytes()).unwrap();
            cmds.push(text);
        }
        (cmds, port)
    })
}

/// The computer end's device path (for spawning the binary).
pub fn path_of(slave: &TTYPort) -> String {
    slave.name().expect("a pty slave has a path")
}

/// A plan of 30 degrees about Y in the scenario `model` (at least 3 steps), written to
/// `dir/plan.csv` as `spherestep plan` writes it.
pub fn broad_plan(dir: &Path, model: &str) -> PathBuf {
    let sc = Scenario::load(Path::new(model)).unwrap();
    let o = PlanOverrides {
        axis: Some("0,1,0".into()),
        angle_deg: Some(30.0),
        ..Default::default()
    };
    let p = planner::plan(&sc.motor(), &plan_settings(&sc, &o).unwrap());
    assert!(p.rows.len() >= 4, "{:?}", p.message);
    let mut csv = Vec::new();
    write_plan(&p.rows, &mut csv).unwrap();
    let path = dir.join("plan.csv");
    std::fs::write(&path, csv).unwrap();
    path
}

/// The relay error inside a library error (a panic naming it when it is another kind).
pub fn relay(e: &Error) -> &RelayError {
    match e {
        Error::Relay(r) => r,
        other => panic!("expected a relay error, got: {other}"),
    }
}

/// A library error as the command line words it (a replay's settings as their flags).
pub fn flagged(e: &Error) -> String {
    e.worded(&replay::Flags)
}

/// Waits (up to 5 s) until the computer end `slave` sees its board end closed. The kernel hangs
/// a pseudo-terminal up after its other end closes, not at once: a write in between still
/// succeeds, so a test that closes a board end and then expects the next write to fail waits
/// for the hangup first.
pub fn await_hangup(slave: &TTYPort) {
    use nix::poll::{poll, PollFd, PollFlags};
    use std::os::unix::io::AsRawFd;
    let deadline = Instant::now() + Duration::from_secs(5);
    while Instant::now() < deadline {
        let mut fds = [PollFd::new(slave.as_raw_fd(), PollFlags::POLLHUP)];
        if poll(&mut fds, 50).is_ok_and(|n| n > 0)
            && fds[0]
                .revents()
                .is_some_and(|r| r.contains(PollFlags::POLLHUP))
        {
            return;
        }
    }
    panic!("the pseudo-terminal did not hang up within 5 s of its board end closing");
}
