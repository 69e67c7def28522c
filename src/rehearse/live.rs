//! The virtual motor on pseudo-terminals: one per relay board and one for the sensor, each
//! served by a thread that answers its protocol ([`super::boards`], [`super::sensor`]); the
//! ball ([`super::plant`]) moves in real time (scaled by the speed) under the coils the relays
//! hold; the limits are watched and every violation recorded; a log CSV and a summary at the
//! end. It ends when the stop flag is set (Ctrl-C, SIGTERM) or when every port that was opened
//! by the replaying side has been closed again. Linux and other Unix systems (a pty master
//! sees the far end hang up as POLLHUP).

use super::boards::{Action, BoardEmulator, Frame};
use super::plant::Ball;
use super::sensor::{garbled_line, quat_csv_line, Bno055Emulator, Request};
use super::{Options, RehearseError, Summary, MAX_VIOLATIONS};
use crate::model::geometry::{CoilId, Orientation};
use crate::planning::closed_loop::Noise;
use crate::relay::{Channel, Slot};
use crate::sensor::SensorFormat;
use nix::poll::{poll, PollFd, PollFlags};
use serialport::{SerialPort, TTYPort};
use std::collections::{BTreeMap, BTreeSet};
use std::io::Write;
use std::os::unix::io::AsRawFd;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// How often the ports are looked at and the ball and the limits brought up to date.
const TICK: Duration = Duration::from_millis(10);

/// How often a quat-csv sensor prints a line (wall clock: 50 Hz, a common IMU sketch's rate).
const LINE_PERIOD: Duration = Duration::from_millis(20);

/// The state every port's thread shares.
struct World {
    ball: Ball,
    started: Instant,
    speed: f64,
    /// The virtual clock's reading at the ball's last update, s.
    t: f64,
    boards: Vec<BoardEmulator>,
    /// Board and channel of each coil (the plant's coil map, inverted).
    coil_of: BTreeMap<Slot, CoilId>,
    /// The relay stuck open (never closes).
    stuck: Option<Slot>,
    /// Every relay on and since when (virtual clock), and whether its on-time was reported.
    on_since: BTreeMap<Slot, (f64, bool)>,
    max_coils_on: usize,
    max_on_time: f64,
    violations: Vec<String>,
    violations_total: usize,
    frames: Vec<usize>,
    unknown_frames: usize,
    readings: usize,
    garbled: usize,
    /// The sensor's readings as sent (noise and mounting): its own generator.
    noise: Noise,
    mount: Orientation,
    garble: f64,
    garble_rng: Noise,
    log: Option<std::io::BufWriter<std::fs::File>>,
    log_path: Option<PathBuf>,
    log_error: Option<String>,
    /// The most coils on at once.
    peak_on: usize,
}

impl World {
    /// The world at the start: the ball where the options put it, every relay open.
    fn new(opts: &Options, log: Option<std::io::BufWriter<std::fs::File>>) -> World {
        World {
            ball: opts.ball.clone(),
            started: Instant::now(),
            speed: opts.speed,
            t: 0.0,
            boards: (opts.boards.iter())
                .map(|b| BoardEmulator::new(b.kind, b.channels, b.slave_address))
                .collect(),
            coil_of: opts.coil_of.clone(),
            stuck: opts.faults.stuck_relay,
            on_since: BTreeMap::new(),
            max_coils_on: opts.max_coils_on,
            max_on_time: opts.max_on_time.as_secs_f64(),
            violations: Vec::new(),
            violations_total: 0,
            frames: vec![0; opts.boards.len()],
            unknown_frames: 0,
            readings: 0,
            garbled: 0,
            noise: Noise::new(opts.seed, opts.sensor_noise),
            mount: opts.mount,
            garble: opts.faults.sensor_garble,
            garble_rng: Noise::new(
                opts.seed ^ 0x5EED_6A4B_1E00_0001,
                crate::model::geometry::Radians(0.0),
            ),
            log,
            log_path: opts.log.clone(),
            log_error: None,
            peak_on: 0,
        }
    }

    /// The end, once every port's thread has stopped: the relays still on reported, the log
    /// closed, the summary.
    fn finish(&mut self, ports: Vec<PortInfo>, ended_by: String) -> Summary {
        self.update();
        let on_at_end = self.closed();
        if !on_at_end.is_empty() {
            let names: Vec<String> = on_at_end.iter().map(|&s| self.coil_name(s)).collect();
            self.violation(format!(
                "{} still on at the end ({})",
                if names.len() == 1 {
                    "a relay is"
                } else {
                    "relays are"
                },
                names.join(", ")
            ));
        }
        self.log_row("-", "end", &format!("ended by {ended_by}"));
        if let Some(mut l) = self.log.take() {
            if let Err(e) = l.flush() {
                self.log_error.get_or_insert(e.to_string());
            }
        }
        let q = self.ball.orientation();
        let c = q.quaternion();
        Summary {
            ports,
            ended_by,
            virtual_time_s: self.t,
            frames: self.frames.clone(),
            unknown_frames: self.unknown_frames,
            sensor_readings: self.readings,
            garbled_readings: self.garbled,
            most_relays_on: self.peak_on,
            relays_on_at_end: on_at_end.iter().map(|s| s.to_string()).collect(),
            coils_on_at_end: self.coils_on().iter().map(|c| c.0).collect(),
            final_orientation: [c.i, c.j, c.k, c.w],
            violations: self.violations.clone(),
            violations_total: self.violations_total,
            log: self.log_path.clone(),
            log_error: self.log_error.clone(),
        }
    }

    fn now(&self) -> f64 {
        self.started.elapsed().as_secs_f64() * self.speed
    }

    /// Brings the ball up to now, and reports coils on past the on-time limit.
    fn update(&mut self) {
        let now = self.now();
        let dt = now - self.t;
        if dt > 0.0 {
            self.ball.advance(dt);
            self.t = now;
        }
        let mut late = Vec::new();
        for (slot, (since, told)) in self.on_since.iter_mut() {
            if !*told && now - *since > self.max_on_time {
                *told = true;
                late.push((*slot, now - *since));
            }
        }
        for (slot, on) in late {
            let coil = self.coil_name(slot);
            self.violation(format!(
                "{coil} (board {}, channel {}) on for {on:.3} s, past max_on_time_s ({:.3} s)",
                slot.board, slot.channel, self.max_on_time
            ));
        }
    }

    fn coil_name(&self, slot: Slot) -> String {
        match self.coil_of.get(&slot) {
            Some(c) => format!("coil {c}"),
            None => "an unmapped relay".into(),
        }
    }

    fn violation(&mut self, what: String) {
        self.violations_total += 1;
        let t = self.t;
        self.log_row("-", "violation", &what);
        if self.violations.len() < MAX_VIOLATIONS {
            self.violations.push(format!("t = {t:.3} s: {what}"));
        }
    }

    /// The relays that are closed (the stuck one never is), by board and channel.
    fn closed(&self) -> BTreeSet<Slot> {
        let mut on = BTreeSet::new();
        for (b, em) in self.boards.iter().enumerate() {
            for (i, &r) in em.relays.iter().enumerate() {
                let slot = Slot {
                    board: b,
                    channel: Channel(i as u16 + 1),
                };
                if r && Some(slot) != self.stuck {
                    on.insert(slot);
                }
            }
        }
        on
    }

    /// The coils on now (the mapped relays that are closed).
    fn coils_on(&self) -> BTreeSet<CoilId> {
        self.closed()
            .iter()
            .filter_map(|s| self.coil_of.get(s).copied())
            .collect()
    }

    /// After the relays changed: the ball's pulls, the on-times, the supply limit.
    fn relays_changed(&mut self) {
        let closed = self.closed();
        let now = self.t;
        self.on_since.retain(|s, _| closed.contains(s));
        for s in &closed {
            self.on_since.entry(*s).or_insert((now, false));
        }
        let coils = self.coils_on();
        self.ball.set_coils(&coils);
        self.peak_on = self.peak_on.max(closed.len());
        if closed.len() > self.max_coils_on {
            let names: Vec<String> = closed.iter().map(|&s| self.coil_name(s)).collect();
            self.violation(format!(
                "{} relays on at once ({}), more than max_coils_on ({})",
                closed.len(),
                names.join(", "),
                self.max_coils_on
            ));
        }
    }

    fn log_row(&mut self, port: &str, frame: &str, what: &str) {
        if self.log.is_none() {
            return;
        }
        let q = self.ball.orientation();
        let c = q.quaternion();
        let coils: Vec<String> = self
            .closed()
            .iter()
            .map(|s| match self.coil_of.get(s) {
                Some(c) => c.to_string(),
                None => format!("{}:{}", s.board, s.channel),
            })
            .collect();
        let row = format!(
            "{:.4},{port},\"{}\",\"{}\",{},{:.6},{:.6},{:.6},{:.6}\n",
            self.t,
            frame.replace('"', "'"),
            what.replace('"', "'"),
            coils.join(";"),
            c.i,
            c.j,
            c.k,
            c.w
        );
        let Some(log) = self.log.as_mut() else {
            return;
        };
        if let Err(e) = log.write_all(row.as_bytes()) {
            self.log_error.get_or_insert(e.to_string());
            self.log = None;
        }
    }

    /// A frame a board received.
    fn frame(&mut self, board: usize, f: &Frame) {
        self.frames[board] += 1;
        let what = match &f.action {
            Action::Set(ch, on) => format!("channel {ch} {}", if *on { "on" } else { "off" }),
            Action::WriteAll(_) => "all relays written".into(),
            Action::Read => "read back".into(),
            Action::Unknown(why) => format!("not understood: {why}"),
        };
        if let Some(s) = self.stuck.filter(|s| s.board == board) {
            if let Some(r) = self.boards[board]
                .relays
                .get_mut(usize::from(s.channel.0) - 1)
            {
                *r = false; // stuck open: what it reads back too
            }
        }
        self.relays_changed();
        self.log_row(&format!("board{board}"), &f.shown(), &what);
        if let Action::Unknown(why) = &f.action {
            self.unknown_frames += 1;
            self.violation(format!(
                "board {board}: a frame not understood ({}): {why}",
                f.shown()
            ));
        }
    }

    /// The orientation the sensor reports now (mounting, noise), and whether to garble it.
    fn reading(&mut self) -> (Orientation, bool) {
        self.update();
        self.readings += 1;
        let q = self.noise.measure(&(self.ball.orientation() * self.mount));
        let garble = self.garble > 0.0 && self.garble_rng.uniform() < self.garble;
        if garble {
            self.garbled += 1;
        }
        (q, garble)
    }
}

fn lock(w: &Mutex<World>) -> MutexGuard<'_, World> {
    // a thread that panicked holding the lock leaves the state as it was: go on with it
    w.lock().unwrap_or_else(|e| e.into_inner())
}

/// What a port's poll found.
enum Seen {
    Nothing,
    Bytes(Vec<u8>),
    /// Nobody has the far end open (before the replay opens it, or after it closed it).
    HungUp,
}

/// Looks at a pty master for `wait`: bytes (read, even when the far end has just closed), or
/// nobody there.
fn look(fd: i32, wait: Duration) -> Seen {
    let mut fds = [PollFd::new(fd, PollFlags::POLLIN)];
    let ms = wait.as_millis().min(1000) as i32;
    match poll(&mut fds, ms) {
        Ok(0) | Err(_) => Seen::Nothing,
        Ok(_) => {
            let ev = fds[0].revents().unwrap_or(PollFlags::empty());
            if ev.contains(PollFlags::POLLIN) {
                let mut buf = [0u8; 512];
                match nix::unistd::read(fd, &mut buf) {
                    Ok(n) if n > 0 => return Seen::Bytes(buf[..n].to_vec()),
                    _ => {}
                }
            }
            if ev.intersects(PollFlags::POLLHUP | PollFlags::POLLERR) {
                std::thread::sleep(wait);
                Seen::HungUp
            } else {
                Seen::Nothing
            }
        }
    }
}

/// Writes all of `bytes` to a pty master, giving up after a second of no room (the far end
/// not reading) or when it is gone.
fn send(fd: i32, mut bytes: &[u8]) -> bool {
    let deadline = Instant::now() + Duration::from_secs(1);
    while !bytes.is_empty() {
        let mut fds = [PollFd::new(fd, PollFlags::POLLOUT)];
        match poll(&mut fds, 50) {
            Ok(n) if n > 0 => match nix::unistd::write(fd, bytes) {
                Ok(k) => bytes = &bytes[k..],
                Err(_) => return false,
            },
            _ => {}
        }
        if Instant::now() > deadline {
            return false;
        }
    }
    true
}

/// One port's connection: whether the replaying side has it open, had it, and is done.
#[derive(Default)]
struct Conn {
    open: AtomicBool,
    was_open: AtomicBool,
    /// Dropped by a fault: counts as closed for good.
    gone: AtomicBool,
}

impl Conn {
    fn seen(&self, open: bool) -> (bool, bool) {
        let before = self.open.swap(open, Ordering::SeqCst);
        if open {
            self.was_open.store(true, Ordering::SeqCst);
        }
        (before, open)
    }
}

/// A pseudo-terminal: its master and the path the replay opens.
fn open_pty() -> Result<(TTYPort, String), RehearseError> {
    let (master, slave) = TTYPort::pair().map_err(|e| RehearseError::Pty(e.to_string()))?;
    let path = slave
        .name()
        .ok_or_else(|| RehearseError::Pty("a pseudo-terminal without a path".into()))?;
    drop(slave); // the replaying side opens it; its closing is then seen as a hang-up
    Ok((master, path))
}

/// `dir/name` -> `target`, replacing an older link of that name (never another file).
fn link(dir: &Path, name: &str, target: &str) -> Result<PathBuf, RehearseError> {
    let at = dir.join(name);
    let err = |e: std::io::Error| RehearseError::LinkDir {
        path: at.clone(),
        reason: e.to_string(),
    };
    if let Ok(m) = std::fs::symlink_metadata(&at) {
        if !m.file_type().is_symlink() {
            return Err(RehearseError::LinkDir {
                path: at.clone(),
                reason: "exists and is not a symbolic link (left alone)".into(),
            });
        }
        // a link to a port that still exists may be another virtual motor's, in use
        if std::fs::metadata(&at).is_ok() {
            let to = std::fs::read_link(&at).unwrap_or_default();
            return Err(RehearseError::LinkDir {
                path: at.clone(),
                reason: format!(
                    "links to {}, a port that exists (another virtual motor's?): left alone; \
                     give another link directory, or end what serves it",
                    to.display()
                ),
            });
        }
        std::fs::remove_file(&at).map_err(err)?;
    }
    std::os::unix::fs::symlink(target, &at).map_err(err)?;
    Ok(at)
}

/// The links a run made, removed when it ends, whichever way (each only while it still links
/// to the port it was made for).
#[derive(Default)]
struct Links(Vec<(PathBuf, String)>);

impl Drop for Links {
    fn drop(&mut self) {
        for (at, target) in &self.0 {
            if std::fs::read_link(at).is_ok_and(|t| t == Path::new(target)) {
                let _ = std::fs::remove_file(at);
            }
        }
    }
}

/// The pseudo-terminals made: what each is, its path and its stable link.
#[derive(Debug, Clone, serde::Serialize)]
pub struct PortInfo {
    /// What the port is, in words ("board 0 (lcus, 8 channels)", "sensor (quat-csv: ...)").
    pub what: String,
    /// The pseudo-terminal the replaying side opens.
    pub path: String,
    /// Its stable link in the link directory, if one was given.
    pub link: Option<PathBuf>,
}

/// Runs the virtual motor until `stop` is set or the replaying side has closed every port it
/// opened; `ready` is told the ports once they exist (before anything is served).
pub fn run(
    opts: &Options,
    stop: Arc<AtomicBool>,
    ready: &mut dyn FnMut(&[PortInfo]),
) -> Result<Summary, RehearseError> {
    if let Some(d) = &opts.link_dir {
        std::fs::create_dir_all(d).map_err(|e| RehearseError::LinkDir {
            path: d.clone(),
            reason: e.to_string(),
        })?;
    }
    let log = open_log(opts)?;
    let mut masters = Vec::new();
    let mut infos = Vec::new();
    let mut links = Links::default();
    for (k, b) in opts.boards.iter().enumerate() {
        let what = format!("board {k} ({}, {} channels)", b.kind, b.channels);
        let (m, info) = make_port(opts, &format!("board{k}"), what, &mut links)?;
        infos.push(info);
        masters.push(m);
    }
    let sensor = match opts.sensor {
        None => None,
        Some(f) => {
            let (m, info) = make_port(opts, "sensor", sensor_port(f), &mut links)?;
            infos.push(info);
            Some((f, m))
        }
    };
    let world = Arc::new(Mutex::new(World::new(opts, log)));
    ready(&infos);
    let conns: Vec<Arc<Conn>> = (0..infos.len())
        .map(|_| Arc::new(Conn::default()))
        .collect();
    let done = Arc::new(AtomicBool::new(false));
    let threads = serve(opts, masters, sensor, &world, &conns, &done);
    let ended_by = watch(opts, &world, &conns, &stop);
    done.store(true, Ordering::SeqCst);
    for t in threads {
        let _ = t.join();
    }
    let mut w = lock(&world);
    Ok(w.finish(infos, ended_by))
}

/// What the sensor's port is, with the order of its quaternion: w first, as the devices send
/// it (a quat-csv sketch's lines, the BNO055's registers 0x20..0x27), where the summary and the
/// log write the ball as the library does, x,y,z,w.
fn sensor_port(f: SensorFormat) -> String {
    match f {
        SensorFormat::QuatCsv => format!("sensor ({f}: lines w,x,y,z, as the device sends them)"),
        SensorFormat::Bno055 => {
            format!("sensor ({f}: quaternion registers w,x,y,z, as the device has them)")
        }
    }
}

/// The log CSV, its header written (none without `opts.log`).
fn open_log(opts: &Options) -> Result<Option<std::io::BufWriter<std::fs::File>>, RehearseError> {
    let Some(p) = &opts.log else {
        return Ok(None);
    };
    let err = |e: std::io::Error| RehearseError::Log {
        path: p.clone(),
        reason: e.to_string(),
    };
    let mut f = std::fs::File::create(p).map_err(err)?;
    // the ball in the library's order, as the summary (the sensor's lines and registers are
    // w first, as the devices send them)
    f.write_all(b"t_s,port,frame,what,coils_on,qx,qy,qz,qw\n")
        .map_err(err)?;
    Ok(Some(std::io::BufWriter::new(f)))
}

/// A pseudo-terminal for `what`, with its link `name` in the link directory if there is one.
fn make_port(
    opts: &Options,
    name: &str,
    what: String,
    links: &mut Links,
) -> Result<(TTYPort, PortInfo), RehearseError> {
    let (m, path) = open_pty()?;
    let link = match &opts.link_dir {
        Some(d) => {
            let at = link(d, name, &path)?;
            links.0.push((at.clone(), path.clone()));
            Some(at)
        }
        None => None,
    };
    Ok((m, PortInfo { what, path, link }))
}

/// Starts a thread serving each port: the boards' (in order), then the sensor's.
fn serve(
    opts: &Options,
    masters: Vec<TTYPort>,
    sensor: Option<(SensorFormat, TTYPort)>,
    world: &Arc<Mutex<World>>,
    conns: &[Arc<Conn>],
    done: &Arc<AtomicBool>,
) -> Vec<std::thread::JoinHandle<()>> {
    let mut threads = Vec::new();
    for (k, m) in masters.into_iter().enumerate() {
        let (w, c, done) = (world.clone(), conns[k].clone(), done.clone());
        let f = opts.faults;
        let faults = BoardFaults {
            drop_after: f.drop_after_frames.filter(|_| k == f.board),
            silent_after: f.silent_after_frames.filter(|_| k == f.board),
        };
        threads.push(std::thread::spawn(move || {
            serve_board(k, m, &w, &c, &done, faults)
        }));
    }
    if let Some((f, m)) = sensor {
        let k = conns.len() - 1;
        let (w, c, done) = (world.clone(), conns[k].clone(), done.clone());
        let stall = opts.faults.sensor_stall_after;
        threads.push(std::thread::spawn(move || {
            serve_sensor(f, m, &w, &c, &done, stall)
        }));
    }
    threads
}

/// Keeps the ball up to date every tick until a signal, the time limit or the replaying side
/// closing every port it opened: which of them ended it.
fn watch(opts: &Options, world: &Mutex<World>, conns: &[Arc<Conn>], stop: &AtomicBool) -> String {
    loop {
        std::thread::sleep(TICK);
        lock(world).update();
        if stop.load(Ordering::SeqCst) {
            break "a signal (Ctrl-C or SIGTERM)".to_string();
        }
        if let Some(limit) = opts.max_seconds {
            if lock(world).started.elapsed() >= limit {
                break format!("its time limit ({} s)", limit.as_secs_f64());
            }
        }
        let any_was = conns.iter().any(|c| c.was_open.load(Ordering::SeqCst));
        let all_closed = conns
            .iter()
            .all(|c| c.gone.load(Ordering::SeqCst) || !c.open.load(Ordering::SeqCst));
        if any_was && all_closed {
            break "the replaying side closing its ports".to_string();
        }
    }
}

/// The faults of one board: after how many frames its port vanishes, or it stops answering.
#[derive(Debug, Clone, Copy)]
struct BoardFaults {
    drop_after: Option<usize>,
    silent_after: Option<usize>,
}

/// Serves one board's pty until the end (or the fault that drops it).
fn serve_board(
    k: usize,
    master: TTYPort,
    world: &Mutex<World>,
    conn: &Conn,
    done: &AtomicBool,
    faults: BoardFaults,
) {
    let fd = master.as_raw_fd();
    let port = format!("board{k}");
    let mut hung = false;
    while !done.load(Ordering::SeqCst) {
        match look(fd, TICK) {
            Seen::Nothing => {
                if !conn.seen(true).0 {
                    lock(world).log_row(&port, "open", "the replaying side opened the port");
                }
            }
            Seen::Bytes(b) => {
                conn.seen(true);
                let mut w = lock(world);
                w.update();
                if faults.silent_after.is_some_and(|n| w.frames[k] >= n) {
                    // a hung board: what it is sent is lost, its relays hold
                    if !std::mem::replace(&mut hung, true) {
                        w.log_row(
                            &port,
                            "silent",
                            "fault: the board stopped answering, its port open; its relays hold",
                        );
                    }
                    continue;
                }
                let frames = w.boards[k].feed(&b);
                for f in &frames {
                    w.frame(k, f);
                    if !f.reply.is_empty() {
                        send(fd, &f.reply);
                    }
                    if faults.drop_after.is_some_and(|n| w.frames[k] >= n) {
                        // the board is unplugged: its relays lose power, the port vanishes
                        for r in w.boards[k].relays.iter_mut() {
                            *r = false;
                        }
                        w.relays_changed();
                        w.log_row(
                            &port,
                            "dropped",
                            "fault: the port vanished; its relays released",
                        );
                        conn.gone.store(true, Ordering::SeqCst);
                        drop(w);
                        drop(master);
                        return;
                    }
                }
            }
            Seen::HungUp => {
                if conn.seen(false).0 {
                    let mut w = lock(world);
                    w.update();
                    if let Some(f) = w.boards[k].leftover() {
                        w.frame(k, &f);
                    }
                    w.log_row(&port, "closed", "the replaying side closed the port");
                    let on: Vec<String> = (w.closed().iter())
                        .filter(|s| s.board == k)
                        .map(|&s| w.coil_name(s))
                        .collect();
                    if !on.is_empty() {
                        w.violation(format!("board {k}'s port closed with {} on", on.join(", ")));
                    }
                }
            }
        }
    }
}

/// Serves the sensor's pty until the end: quat-csv lines at 50 Hz while the port is open, or
/// the BNO055's replies.
fn serve_sensor(
    format: SensorFormat,
    master: TTYPort,
    world: &Mutex<World>,
    conn: &Conn,
    done: &AtomicBool,
    stall_after: Option<usize>,
) {
    let fd = master.as_raw_fd();
    let mut bno = Bno055Emulator::default();
    let mut next_line = Instant::now();
    let mut served = 0usize;
    let stalled = |served: usize| stall_after.is_some_and(|n| served >= n);
    while !done.load(Ordering::SeqCst) {
        let wait = match format {
            SensorFormat::QuatCsv => LINE_PERIOD.min(TICK),
            SensorFormat::Bno055 => TICK,
        };
        match look(fd, wait) {
            Seen::HungUp => {
                if conn.seen(false).0 {
                    lock(world).log_row("sensor", "closed", "the replaying side closed the port");
                }
                continue;
            }
            Seen::Nothing => {
                if !conn.seen(true).0 {
                    lock(world).log_row("sensor", "open", "the replaying side opened the port");
                }
            }
            Seen::Bytes(b) => {
                conn.seen(true);
                if format == SensorFormat::Bno055 {
                    served += answer_bno(&mut bno, &b, fd, world, stalled(served));
                }
            }
        }
        let due = Instant::now() >= next_line && !stalled(served);
        if format == SensorFormat::QuatCsv && conn.open.load(Ordering::SeqCst) && due {
            next_line += LINE_PERIOD;
            if next_line < Instant::now() {
                next_line = Instant::now() + LINE_PERIOD;
            }
            let line = csv_line(world);
            served += 1;
            send(fd, line.as_bytes());
        }
    }
}

/// Answers the BNO055 requests in `bytes` (nothing once the sensor has stalled), a reading
/// garbled on the wire when the fault says so: how many readings were taken.
fn answer_bno(
    bno: &mut Bno055Emulator,
    bytes: &[u8],
    fd: i32,
    world: &Mutex<World>,
    stalled: bool,
) -> usize {
    let mut w = lock(world);
    let mut garble = false;
    let mut reads = 0usize;
    let mut now = || {
        reads += 1;
        let (q, g) = w.reading();
        garble |= g;
        q
    };
    let replies = if stalled {
        Vec::new()
    } else {
        bno.feed(bytes, &mut now)
    };
    for (req, mut reply) in replies {
        if let Request::Unknown(why) = &req {
            let why = why.clone();
            w.violation(format!("sensor: a request not understood: {why}"));
        }
        if garble
            && matches!(
                req,
                Request::Read {
                    quaternion: true,
                    ..
                }
            )
        {
            reply[0] = 0x5A; // corrupted on the wire
        }
        send(fd, &reply);
    }
    reads
}

/// The quat-csv line the sensor prints now (a garbled one when the fault says so).
fn csv_line(world: &Mutex<World>) -> String {
    let mut w = lock(world);
    let (q, g) = w.reading();
    if g {
        garbled_line(&q)
    } else {
        quat_csv_line(&q)
    }
}
