//! The orientation sensor drivers on pseudo-terminals: a quat-csv sensor printing lines and a
//! BNO055 answering register requests are played on the far end; every test checks the bytes
//! on the wire and the numbers decoded, and guards against hangs.

use serialport::{SerialPort, TTYPort};
use spherestep::sensor::bno055::FusionMode;
use spherestep::sensor::{
    self, bno055, OrientationSensor, Raw, Reading, SensorError, SensorFormat,
};
use std::io::{Read, Write};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Longest a far end waits for bytes before giving up (a guard against hangs).
const GUARD: Duration = Duration::from_secs(10);
/// The sensor timeout most tests use.
const TIMEOUT: Duration = Duration::from_millis(300);
/// How long the quat-csv far end waits after being told to print, so the line is printed
/// after the read began.
const PRINT_DELAY: Duration = Duration::from_millis(50);

/// A pseudo-terminal pair: (sensor end, computer end).
fn pty() -> (TTYPort, TTYPort) {
    TTYPort::pair().expect("a pseudo-terminal pair")
}

fn path_of(port: &TTYPort) -> String {
    port.name().expect("a pty slave has a path")
}

/// Reads exactly `n` bytes at the sensor end (panics after `GUARD`).
fn read_n(port: &mut TTYPort, n: usize) -> Vec<u8> {
    let deadline = Instant::now() + GUARD;
    let mut got = Vec::new();
    let mut buf = [0u8; 256];
    while got.len() < n {
        assert!(Instant::now() < deadline, "sensor end got only {got:02X?}");
        let want = (n - got.len()).min(buf.len());
        match port.read(&mut buf[..want]) {
            Ok(k) => got.extend_from_slice(&buf[..k]),
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
            Err(e) => panic!("sensor end read failed: {e}"),
        }
    }
    got
}

fn assert_quat(r: &Reading, wxyz: [f64; 4]) {
    let q = r.orientation;
    let got = [q.w, q.i, q.j, q.k];
    for (g, e) in got.iter().zip(wxyz) {
        assert!((g - e).abs() < 1e-12, "got {got:?}, expected {wxyz:?}");
    }
    assert!((q.quaternion().norm() - 1.0).abs() < 1e-12);
}

fn normalised(wxyz: [f64; 4]) -> [f64; 4] {
    let n = wxyz.iter().map(|c| c * c).sum::<f64>().sqrt();
    wxyz.map(|c| c / n)
}

// ---------------------------------------------------------------- quat-csv

/// A quat-csv sensor end: for every batch of chunks received, waits `PRINT_DELAY`, then
/// writes the chunks 10 ms apart. Ends when the sender is dropped; returns its port.
fn printer(mut port: TTYPort) -> (mpsc::Sender<Vec<Vec<u8>>>, JoinHandle<TTYPort>) {
    let (tx, rx) = mpsc::channel::<Vec<Vec<u8>>>();
    let h = std::thread::spawn(move || {
        while let Ok(chunks) = rx.recv_timeout(GUARD) {
            std::thread::sleep(PRINT_DELAY);
            for (k, c) in chunks.iter().enumerate() {
                if k > 0 {
                    std::thread::sleep(Duration::from_millis(10));
                }
                port.write_all(c).expect("the sensor end writes");
            }
        }
        port
    });
    (tx, h)
}

fn one(line: &str) -> Vec<Vec<u8>> {
    vec![line.as_bytes().to_vec()]
}

/// Reads `s`, which must time out after [`TIMEOUT`] (within a second more) saying `message`.
fn times_out(s: &mut dyn OrientationSensor, message: &str) {
    let t = Instant::now();
    let e = s.read().unwrap_err();
    let took = t.elapsed();
    assert!(matches!(e, SensorError::Timeout { .. }), "{e:?}");
    assert_eq!(e.to_string(), message);
    assert!(
        took >= TIMEOUT && took < TIMEOUT + Duration::from_secs(1),
        "{took:?}"
    );
}

fn quat_csv_on(slave: TTYPort, timeout: Duration) -> Box<dyn OrientationSensor> {
    sensor::from_port(SensorFormat::QuatCsv, Box::new(slave), "pty", timeout)
        .expect("a quat-csv sensor")
}

/// What the far end prints (in chunks), the line expected back, and the quaternion w, x, y, z.
type Printed = (Vec<Vec<u8>>, &'static str, [f64; 4]);

#[test]
fn quat_csv_readings_are_the_printed_quaternions_normalised() {
    let _one = crate::one_at_a_time();
    let (master, slave) = pty();
    let path = path_of(&slave);
    // Through `open`, by path, as the binary will.
    let mut s = sensor::open(
        SensorFormat::QuatCsv,
        FusionMode::Imu,
        &path,
        115_200,
        TIMEOUT,
    )
    .unwrap();
    assert_eq!(s.describe(), format!("quat-csv sensor on {path}"));
    let (tx, h) = printer(master);
    let cases: Vec<Printed> = vec![
        (one("1,0,0,0\n"), "1,0,0,0", [1.0, 0.0, 0.0, 0.0]),
        (
            one("0.5,-0.5,0.5,-0.5\r\n"),
            "0.5,-0.5,0.5,-0.5",
            [0.5, -0.5, 0.5, -0.5],
        ),
        (
            one(" 0.9, 0.3 ,-0.3,0.1\n"),
            " 0.9, 0.3 ,-0.3,0.1",
            normalised([0.9, 0.3, -0.3, 0.1]),
        ),
        // Within 0.1 of norm 1: normalised, the sign kept.
        (one("0,0,0,-1.05\n"), "0,0,0,-1.05", [0.0, 0.0, 0.0, -1.0]),
        (
            one("0.6,0,0.8,0.06\r\n"),
            "0.6,0,0.8,0.06",
            normalised([0.6, 0.0, 0.8, 0.06]),
        ),
        // One line in three pieces, across reads of the port.
        (
            vec![b"0.7,0".to_vec(), b".7,0.1".to_vec(), b",0.1\r\n".to_vec()],
            "0.7,0.7,0.1,0.1",
            [0.7, 0.7, 0.1, 0.1],
        ),
        // Blank lines are skipped.
        (
            vec![b"\r\n".to_vec(), b"\n".to_vec(), b"0,1,0,0\n".to_vec()],
            "0,1,0,0",
            [0.0, 1.0, 0.0, 0.0],
        ),
    ];
    for (chunks, line, wxyz) in cases {
        tx.send(chunks).unwrap();
        let r = s.read().unwrap_or_else(|e| panic!("{line}: {e}"));
        assert_eq!(r.raw, Raw::Line(line.to_string()));
        assert_quat(&r, wxyz);
    }
    drop(tx);
    h.join().unwrap();
}

#[test]
fn quat_csv_skips_stale_lines_and_a_half_line_from_before_the_read() {
    let _one = crate::one_at_a_time();
    let (mut master, slave) = pty();
    let mut s = quat_csv_on(slave, Duration::from_secs(2));
    // Buffered before the read: two readings, garbage, and the start of a line.
    master
        .write_all(b"1,0,0,0\r\nnot a reading\n0,0,0,1\n0,0,1")
        .unwrap();
    std::thread::sleep(Duration::from_millis(200));
    let (tx, h) = printer(master);
    // After the read began: the end of the half line, then a fresh one.
    tx.send(vec![b",0\n".to_vec(), b"0,1,0,0\n".to_vec()])
        .unwrap();
    let r = s.read().unwrap();
    assert_eq!(r.raw, Raw::Line("0,1,0,0".into()));
    assert_quat(&r, [0.0, 1.0, 0.0, 0.0]);
    drop(tx);
    h.join().unwrap();
}

#[test]
fn quat_csv_garbage_lines_and_bad_norms_are_errors_with_the_line() {
    let _one = crate::one_at_a_time();
    let (master, slave) = pty();
    let mut s = quat_csv_on(slave, Duration::from_secs(2));
    let (tx, h) = printer(master);
    let long = "9".repeat(300);
    let cases: Vec<(String, &str, &str)> = vec![
        ("hello world\r\n".into(), "hello world", "got 1 field(s)"),
        ("1,0,0\n".into(), "1,0,0", "got 3 field(s)"),
        ("1,0,0,0,0\n".into(), "1,0,0,0,0", "got 5 field(s)"),
        (
            "1,0,0,x\r\n".into(),
            "1,0,0,x",
            "field 4 ('x') is not a number",
        ),
        ("1,0,inf,0\n".into(), "1,0,inf,0", "not finite"),
        (
            "2,0,0,0\n".into(),
            "2,0,0,0",
            "the norm 2.0000 is not within 0.1 of 1",
        ),
        (
            "0.5,0.5,0.5,0.1\n".into(),
            "0.5,0.5,0.5,0.1",
            "the norm 0.8718 is not within",
        ),
        (
            format!("{long}\n"),
            &long[..256],
            "no line end within 256 bytes",
        ),
    ];
    for (text, line, reason_part) in &cases {
        tx.send(one(text)).unwrap();
        let e = s.read().expect_err(text);
        let msg = e.to_string();
        let SensorError::Garbage {
            line: got, reason, ..
        } = e
        else {
            panic!("{text:?}: expected garbage, got {msg}");
        };
        assert_eq!(&got, line);
        assert!(reason.contains(reason_part), "{reason}");
        assert!(
            msg.starts_with("sensor pty (quat-csv): garbage line '"),
            "{msg}"
        );
    }
    // The sensor still reads afterwards.
    tx.send(one("0,0,1,0\n")).unwrap();
    assert_quat(&s.read().unwrap(), [0.0, 0.0, 1.0, 0.0]);
    drop(tx);
    h.join().unwrap();
}

/// What a sensor sends is printed with its control characters escaped
/// (NUL bytes, terminal escapes), never raw.
#[test]
fn quat_csv_control_bytes_are_escaped_in_messages() {
    let _one = crate::one_at_a_time();
    let (master, slave) = pty();
    let mut s = quat_csv_on(slave, Duration::from_secs(2));
    let (tx, h) = printer(master);
    tx.send(one("1,\0\0,0,\x1b[2J\n")).unwrap();
    let e = s.read().expect_err("garbage");
    let msg = e.to_string();
    assert!(!msg.contains(['\0', '\u{1b}']), "{msg:?}");
    assert!(
        msg.starts_with("sensor pty (quat-csv): garbage line '1,\\0\\0,0,\\u{1b}[2J': "),
        "{msg}"
    );
    assert!(msg.contains("field 2 ('\\0\\0') is not a number"), "{msg}");
    drop(tx);
    h.join().unwrap();
}

#[test]
fn quat_csv_silence_is_a_timeout() {
    let _one = crate::one_at_a_time();
    let (mut master, slave) = pty();
    let mut s = quat_csv_on(slave, TIMEOUT);
    times_out(
        s.as_mut(),
        "sensor pty (quat-csv): no reading within 300 ms (nothing received)",
    );
    // Only stale lines: still a timeout, which says so.
    master.write_all(b"1,0,0,0\n0,1,0,0\n").unwrap();
    std::thread::sleep(Duration::from_millis(200));
    let e = s.read().unwrap_err();
    assert_eq!(
        e.to_string(),
        "sensor pty (quat-csv): no reading within 300 ms (got only 2 line(s) from before the call, skipped as stale)"
    );
}

#[test]
fn quat_csv_far_end_closed_is_an_error_not_a_hang() {
    let _one = crate::one_at_a_time();
    let (master, slave) = pty();
    let mut s = quat_csv_on(slave, Duration::from_secs(5));
    // Closed while a read waits: the read ends at once, not after its timeout.
    let closer = std::thread::spawn(move || {
        std::thread::sleep(Duration::from_millis(150));
        drop(master);
    });
    let t = Instant::now();
    let e = s.read().unwrap_err();
    assert!(t.elapsed() < Duration::from_secs(2), "{:?}", t.elapsed());
    assert!(matches!(e, SensorError::Closed { .. }), "{e:?}");
    assert_eq!(
        e.to_string(),
        "sensor pty (quat-csv): the sensor end closed the connection while reading"
    );
    // And every later read says the same, at once.
    let t = Instant::now();
    assert!(matches!(s.read(), Err(SensorError::Closed { .. })));
    assert!(t.elapsed() < Duration::from_secs(1));
    closer.join().unwrap();
    // Dropping the sensor stops its reader thread.
    let t = Instant::now();
    drop(s);
    assert!(t.elapsed() < Duration::from_secs(1));
}

#[test]
fn sensor_open_reports_a_missing_port_by_name() {
    let _one = crate::one_at_a_time();
    let e = sensor::open(
        SensorFormat::Bno055,
        FusionMode::Ndof,
        "/dev/does-not-exist-sensor",
        115_200,
        TIMEOUT,
    )
    .err()
    .expect("no such port");
    assert!(matches!(e, SensorError::Open { .. }), "{e:?}");
    assert!(
        e.to_string()
            .starts_with("sensor /dev/does-not-exist-sensor (bno055): cannot open the serial port"),
        "{e}"
    );
}

// ---------------------------------------------------------------- BNO055

/// What the BNO055 end does with one request.
#[derive(Clone, Debug)]
enum Act {
    /// Writes these bytes.
    Reply(Vec<u8>),
    /// Writes the first part, waits, writes the rest (a reply too late).
    Late(Vec<u8>, Duration, Vec<u8>),
    /// Answers nothing.
    Silent,
    /// Closes its end.
    Close,
}

/// One request as the BNO055 end saw it.
#[derive(Debug)]
struct Seen {
    request: Vec<u8>,
    /// When it had fully arrived.
    at: Instant,
    /// When the answer had been written.
    answered: Instant,
}

const ACK: [u8; 2] = [0xEE, 0x01];
const CONFIG_WRITE: [u8; 5] = [0xAA, 0x00, 0x3D, 0x01, 0x00];
const IMU_WRITE: [u8; 5] = [0xAA, 0x00, 0x3D, 0x01, 0x08];
const QUAT_READ: [u8; 4] = [0xAA, 0x01, 0x20, 0x08];

/// A read reply carrying raw w, x, y, z.
fn quat_reply(raw: [i16; 4]) -> Vec<u8> {
    let mut r = vec![0xBB, 0x08];
    for c in raw {
        r.extend(c.to_le_bytes());
    }
    r
}

/// What the BNO055 end saw, and its port unless it closed it.
type Far = JoinHandle<(Vec<Seen>, Option<TTYPort>)>;

/// The BNO055 end: handles one request per act, in order; returns what it saw, and its port
/// (kept open until joined: a pty whose far end closes loses the replies not yet read).
fn bno(mut port: TTYPort, acts: Vec<Act>) -> Far {
    std::thread::spawn(move || {
        let mut seen = Vec::new();
        for act in acts {
            let mut request = read_n(&mut port, 4);
            if request[1] == 0x00 {
                let len = usize::from(request[3]);
                request.extend(read_n(&mut port, len));
            }
            let at = Instant::now();
            match act {
                Act::Reply(b) => port.write_all(&b).unwrap(),
                Act::Late(first, pause, rest) => {
                    port.write_all(&first).unwrap();
                    std::thread::sleep(pause);
                    port.write_all(&rest).unwrap();
                }
                Act::Silent => {}
                Act::Close => {
                    seen.push(Seen {
                        request,
                        at,
                        answered: Instant::now(),
                    });
                    drop(port);
                    return (seen, None);
                }
            }
            seen.push(Seen {
                request,
                at,
                answered: Instant::now(),
            });
        }
        (seen, Some(port))
    })
}

/// Acknowledges both mode writes, then plays `acts`.
fn started(acts: Vec<Act>, timeout: Duration) -> (Box<dyn OrientationSensor>, Far) {
    let (master, slave) = pty();
    let mut all = vec![Act::Reply(ACK.to_vec()), Act::Reply(ACK.to_vec())];
    all.extend(acts);
    let end = bno(master, all);
    let s = sensor::from_port(SensorFormat::Bno055, Box::new(slave), "pty", timeout)
        .expect("the BNO055 starts");
    (s, end)
}

/// The far end's requests, once it is done.
fn requests_of(end: Far) -> Vec<Vec<u8>> {
    requests(&end.join().unwrap().0)
}

fn requests(seen: &[Seen]) -> Vec<Vec<u8>> {
    seen.iter().map(|s| s.request.clone()).collect()
}

#[test]
fn bno055_start_sets_configmode_then_imu_with_the_switching_times() {
    let _one = crate::one_at_a_time();
    let data = [8192, -8192, 8192, -8192];
    let (mut s, end) = started(vec![Act::Reply(quat_reply(data))], TIMEOUT);
    assert_eq!(s.describe(), "BNO055 (UART, IMU mode) on pty");
    s.read().unwrap();
    let seen = end.join().unwrap().0;
    assert_eq!(
        requests(&seen),
        vec![
            CONFIG_WRITE.to_vec(),
            IMU_WRITE.to_vec(),
            QUAT_READ.to_vec()
        ]
    );
    // 19 ms into CONFIGMODE before the next request, 7 ms out of it before the first read.
    let into_config = seen[1].at - seen[0].answered;
    let out_of_config = seen[2].at - seen[1].answered;
    assert!(into_config >= Duration::from_millis(19), "{into_config:?}");
    assert!(
        out_of_config >= Duration::from_millis(7),
        "{out_of_config:?}"
    );
}

#[test]
fn bno055_readings_are_signed_little_endian_over_2_pow_14() {
    let _one = crate::one_at_a_time();
    // w=8192 (0x2000), x=-8192 (0xE000), y=8192, z=-8192, LSB first, written out by hand.
    let by_hand = vec![0xBB, 0x08, 0x00, 0x20, 0x00, 0xE0, 0x00, 0x20, 0x00, 0xE0];
    let cases: Vec<([i16; 4], [f64; 4])> = vec![
        ([16384, 0, 0, 0], [1.0, 0.0, 0.0, 0.0]),
        ([0, 0, 0, -16384], [0.0, 0.0, 0.0, -1.0]),
        // 0.9, 0.3, -0.3, 0.1 rounded to LSB: 14746 = 0x399A, -4915 = 0xECCD.
        (
            [14746, 4915, -4915, 1638],
            normalised([14746.0, 4915.0, -4915.0, 1638.0]),
        ),
        // cos 45, 0, 0, -sin 45: 11585 = 0x2D41.
        (
            [11585, 0, 0, -11585],
            [0.5f64.sqrt(), 0.0, 0.0, -(0.5f64.sqrt())],
        ),
    ];
    let mut acts = vec![Act::Reply(by_hand.clone())];
    acts.extend(cases.iter().map(|(raw, _)| Act::Reply(quat_reply(*raw))));
    let (mut s, end) = started(acts, TIMEOUT);
    let r = s.read().unwrap();
    assert_eq!(r.raw, Raw::Frame(by_hand));
    assert_eq!(r.raw.to_string(), "BB 08 00 20 00 E0 00 20 00 E0");
    assert_quat(&r, [0.5, -0.5, 0.5, -0.5]);
    for (raw, wxyz) in &cases {
        let r = s.read().unwrap();
        assert_eq!(r.raw, Raw::Frame(quat_reply(*raw)));
        assert_quat(&r, *wxyz);
    }
    assert_eq!(
        quat_reply([14746, -4915, 0, 0])[2..6],
        [0x9A, 0x39, 0xCD, 0xEC]
    );
    let seen = end.join().unwrap().0;
    assert!(requests(&seen)[2..].iter().all(|r| r == &QUAT_READ));
    assert_eq!(seen.len(), 2 + 1 + cases.len());
}

#[test]
fn bno055_error_statuses_are_named_and_over_runs_retried() {
    let _one = crate::one_at_a_time();
    let over_run = || Act::Reply(vec![0xEE, 0x07]);
    let mut acts = vec![Act::Reply(vec![0xEE, 0x02])];
    acts.extend((0..bno055::ATTEMPTS).map(|_| over_run()));
    acts.push(over_run());
    acts.push(Act::Reply(quat_reply([0, 16384, 0, 0])));
    let (mut s, end) = started(acts, TIMEOUT);

    let e = s.read().unwrap_err();
    assert!(
        matches!(
            e,
            SensorError::Status {
                status: 0x02,
                attempts: 1,
                ..
            }
        ),
        "{e:?}"
    );
    assert_eq!(
        e.to_string(),
        "sensor pty (bno055): read QUA_Data (0x20, 8 bytes) answered EE 02 READ_FAIL (check the wiring, the UART settings and the operating mode)"
    );

    // BUS_OVER_RUN_ERROR every time: sent ATTEMPTS times, then the error by name.
    let e = s.read().unwrap_err();
    assert!(
        matches!(
            e,
            SensorError::Status {
                status: 0x07,
                attempts: 4,
                ..
            }
        ),
        "{e:?}"
    );
    let msg = e.to_string();
    assert!(msg.contains("answered EE 07 BUS_OVER_RUN_ERROR ("), "{msg}");
    assert!(msg.ends_with(" after 4 attempts"), "{msg}");

    // Once, then an answer: the retry gives the reading.
    assert_quat(&s.read().unwrap(), [0.0, 1.0, 0.0, 0.0]);
    let seen = end.join().unwrap().0;
    assert_eq!(seen.len(), 2 + 1 + 4 + 2);
    assert!(requests(&seen)[2..].iter().all(|r| r == &QUAT_READ));
}

#[test]
fn bno055_refused_mode_write_fails_the_start_by_name() {
    let _one = crate::one_at_a_time();
    let (master, slave) = pty();
    let end = bno(master, vec![Act::Reply(vec![0xEE, 0x03])]);
    let e = sensor::from_port(SensorFormat::Bno055, Box::new(slave), "pty", TIMEOUT)
        .err()
        .expect("the start fails");
    assert_eq!(
        e.to_string(),
        "sensor pty (bno055): write OPR_MODE (0x3D) = 0x00 (CONFIGMODE) answered EE 03 WRITE_FAIL (check the wiring, the UART settings and the operating mode)"
    );
    assert_eq!(requests_of(end), vec![CONFIG_WRITE.to_vec()]);
}

#[test]
fn bno055_zero_quaternion_and_bad_replies_are_errors() {
    let _one = crate::one_at_a_time();
    let (mut s, end) = started(
        vec![
            Act::Reply(quat_reply([0, 0, 0, 0])),
            Act::Reply(quat_reply([8192, 0, 0, 0])),
            // A write's acknowledge is no answer to a read.
            Act::Reply(ACK.to_vec()),
            Act::Reply(quat_reply([0, 0, 16384, 0])),
        ],
        TIMEOUT,
    );
    let e = s.read().unwrap_err();
    assert!(matches!(e, SensorError::NotFused { .. }), "{e:?}");
    assert!(
        e.to_string().starts_with(
            "sensor pty (bno055): the quaternion is all zero: sensor fusion is not running yet"
        ),
        "{e}"
    );
    let e = s.read().unwrap_err();
    assert_eq!(
        e.to_string(),
        "sensor pty (bno055): unexpected reply BB 08 00 20 00 00 00 00 00 00: expected a unit quaternion, but the norm 0.5000 is not within 0.1 of 1"
    );
    let e = s.read().unwrap_err();
    assert!(
        matches!(e, SensorError::BadReply { ref got, .. } if got == &ACK),
        "{e:?}"
    );
    assert_quat(&s.read().unwrap(), [0.0, 0.0, 1.0, 0.0]);
    assert_eq!(requests_of(end).len(), 6);
}

#[test]
fn bno055_silence_and_half_replies_are_timeouts_and_a_late_rest_is_drained() {
    let _one = crate::one_at_a_time();
    let rest = vec![0x40, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00];
    let (mut s, end) = started(
        vec![
            Act::Silent,
            Act::Late(vec![0xBB, 0x08, 0x00], Duration::from_millis(400), rest),
            Act::Reply(quat_reply([0, 0, 0, 16384])),
        ],
        TIMEOUT,
    );
    times_out(
        s.as_mut(),
        "sensor pty (bno055): no complete reply to read QUA_Data (0x20, 8 bytes) within 300 ms (nothing received)",
    );

    let e = s.read().unwrap_err();
    assert_eq!(
        e.to_string(),
        "sensor pty (bno055): no complete reply to read QUA_Data (0x20, 8 bytes) within 300 ms (got 3 byte(s): BB 08 00)"
    );
    // The rest of that reply arrives late; the next read drops it before asking again.
    std::thread::sleep(Duration::from_millis(300));
    let r = s.read().unwrap();
    assert_eq!(r.raw, Raw::Frame(quat_reply([0, 0, 0, 16384])));
    assert_quat(&r, [0.0, 0.0, 0.0, 1.0]);
    assert!(requests_of(end)[2..].iter().all(|r| r == &QUAT_READ));
}

#[test]
fn bno055_far_end_closed_is_an_error_not_a_hang() {
    let _one = crate::one_at_a_time();
    let (mut s, end) = started(vec![Act::Close], Duration::from_secs(5));
    let t = Instant::now();
    let e = s.read().unwrap_err();
    assert!(t.elapsed() < Duration::from_secs(2), "{:?}", t.elapsed());
    // Closed, or (when the far end goes while the request's write is being drained) an Io
    // error: serialport reports a failed drain as a bare "flush failed" without the OS error,
    // which cannot be told from another failure. Either way an error at once, named.
    match &e {
        SensorError::Closed { .. } => assert!(
            e.to_string()
                .starts_with("sensor pty (bno055): the sensor end closed the connection while "),
            "{e}"
        ),
        SensorError::Io { .. } => {
            assert!(e.to_string().starts_with("sensor pty (bno055): "), "{e}")
        }
        _ => panic!("expected Closed or Io, got {e:?}"),
    }
    let t = Instant::now();
    let e = s.read().unwrap_err();
    assert!(t.elapsed() < Duration::from_secs(2), "{:?}", t.elapsed());
    assert!(
        matches!(e, SensorError::Closed { .. } | SensorError::Io { .. }),
        "{e:?}"
    );
    assert!(e.to_string().starts_with("sensor pty (bno055): "), "{e}");
    assert_eq!(requests_of(end)[2], QUAT_READ.to_vec());
}
