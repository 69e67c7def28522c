//! The hardware tier: tests against a real relay board (and, for the sensor's test, a real
//! orientation sensor), run only with the feature `hardware-tests` (ignored otherwise, as
//! serialport-rs does with its own). The devices are named by environment variables; with the
//! feature on, a test whose variable is missing fails saying which to set:
//!
//! - `SPHERESTEP_TEST_PORT`: the relay board's serial device (`/dev/ttyUSB0`); with
//!   `[[relay.boards]]`, one device per board in list order, separated by commas;
//! - `SPHERESTEP_TEST_SCENARIO`: a scenario whose `[relay]` section describes the board(s), or
//!   `SPHERESTEP_TEST_BOARD`: the board type (lcus, kmtronic, numato, modbus) on the built-in
//!   prototype's stator and default map;
//! - `SPHERESTEP_TEST_SENSOR` (the sensor's test only): the sensor's serial device, and
//!   `SPHERESTEP_TEST_SENSOR_FORMAT` (quat-csv, the default, or bno055).
//!
//! ```text
//! SPHERESTEP_TEST_PORT=/dev/ttyUSB0 SPHERESTEP_TEST_BOARD=lcus \
//!     cargo test --release --features hardware-tests --test rig hardware::relay
//! ```
//!
//! Every coil the board drives is switched on for a moment (`examples/hardware_check.rs`):
//! run it with the coil supply off, or with the motor free to turn.

use crate::example;
use spherestep::relay::{connect, BoardKind, Link};
use spherestep::sensor::{self, bno055::FusionMode, SensorFormat};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

/// The environment variable `name`; a panic saying how to set it when it is missing.
fn required(name: &str, what: &str) -> String {
    std::env::var(name).unwrap_or_else(|_| {
        panic!(
            "the hardware-tests feature is on, but {name} is not set: set it to {what} (see \
             TESTING.md, \"The hardware tier\"), or run the tests without the feature"
        )
    })
}

/// The board's devices, from `SPHERESTEP_TEST_PORT`.
fn ports() -> Vec<String> {
    let v = required(
        "SPHERESTEP_TEST_PORT",
        "the relay board's serial device, such as /dev/ttyUSB0 (one per board, separated by commas)",
    );
    v.split(',').map(|p| p.trim().to_string()).collect()
}

/// The wiring check's arguments for the board under test: the scenario (or the prototype with
/// `--board`) and the ports.
fn check_args() -> Vec<String> {
    let mut args = match std::env::var("SPHERESTEP_TEST_SCENARIO") {
        Ok(sc) => vec![sc],
        Err(_) => {
            let board = required(
                "SPHERESTEP_TEST_BOARD",
                "the board type (lcus, kmtronic, numato or modbus), or set \
                 SPHERESTEP_TEST_SCENARIO to a scenario with a [relay] section",
            );
            let prototype = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/prototype.toml");
            vec![prototype.to_string(), "--board".into(), board]
        }
    };
    for p in ports() {
        args.extend(["--port".to_string(), p]);
    }
    args
}

#[test]
#[cfg_attr(
    not(feature = "hardware-tests"),
    ignore = "needs a relay board (feature hardware-tests)"
)]
fn relay_board_every_coil_on_and_off_then_all_off() {
    let _one = crate::one_at_a_time();
    let mut args = check_args();
    args.extend(["--on-ms".to_string(), "100".to_string()]);
    let mut out = Vec::new();
    let r = example::check(&args, Arc::new(AtomicBool::new(false)), &mut out);
    let text = String::from_utf8_lossy(&out);
    println!("{text}");
    if let Err(e) = r {
        panic!("{}\n{text}", e.worded(&example::CheckFlags));
    }
    assert!(text.contains("all coils off"), "{text}");
    let table: Vec<&str> = (text.lines())
        .skip_while(|l| !l.starts_with(" coil board channel"))
        .skip(1)
        .collect();
    assert!(!table.is_empty(), "{text}");
    assert!(
        table
            .iter()
            .all(|l| l.contains("read back") || l.contains("sent")),
        "{text}"
    );
}

#[test]
#[cfg_attr(
    not(feature = "hardware-tests"),
    ignore = "needs a relay board (feature hardware-tests)"
)]
fn relay_board_answers_an_all_off_and_reads_back_nothing_on() {
    let _one = crate::one_at_a_time();
    let args = check_args();
    let prep = example::prepare(&example::parse(&args).unwrap()).unwrap();
    let spec = &prep.boards[0];
    let port = spec.port.clone().expect("a port for board 0");
    let link = Link::open_serial(&port, spec.baud, spec.timeout).unwrap();
    let mut board = connect(spec.kind, spec.channels, spec.slave_address, link).unwrap();
    board.all_off().unwrap();
    if board.read_back().is_ok() {
        let states = board
            .read_states()
            .unwrap()
            .expect("the states of a real board");
        assert_eq!(states.len(), usize::from(spec.channels));
        assert!(states.iter().all(|on| !on), "{states:?}");
    } else {
        assert!(matches!(spec.kind, BoardKind::Lcus | BoardKind::Kmtronic));
    }
}

#[test]
#[cfg_attr(
    not(feature = "hardware-tests"),
    ignore = "needs a sensor (feature hardware-tests)"
)]
fn sensor_gives_unit_quaternions() {
    let _one = crate::one_at_a_time();
    let device = required(
        "SPHERESTEP_TEST_SENSOR",
        "the orientation sensor's serial device, such as /dev/ttyACM0 (or run only \
         `hardware::relay`)",
    );
    let format: SensorFormat = std::env::var("SPHERESTEP_TEST_SENSOR_FORMAT")
        .unwrap_or_else(|_| "quat-csv".into())
        .parse()
        .unwrap_or_else(|e| panic!("SPHERESTEP_TEST_SENSOR_FORMAT: {e}"));
    let timeout = Duration::from_secs(2);
    let mut s = sensor::open(
        format,
        FusionMode::Imu,
        &device,
        format.default_baud(),
        timeout,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(s.describe().contains(&device), "{}", s.describe());
    for _ in 0..5 {
        let r = s.read().unwrap_or_else(|e| panic!("{e}"));
        let n = r.orientation.quaternion().norm();
        assert!((n - 1.0).abs() < 1e-9, "{n} from {}", r.raw);
    }
}
