//! The serial layer under the relay boards and the orientation sensors: what a driver talks
//! over ([`Port`]: anything `Read + Write + Send`, a serial port or a pseudo-terminal in the
//! tests), the one way a device is opened (8N1, no flow control, always with a timeout:
//! serialport's default is 0 ms; with the `hardware` feature) and how bytes are shown.
//!
//! Entry points: [`Port`], `open_8n1` (with the `hardware` feature) and [`hex`].

use std::io::{Read, Write};
#[cfg(feature = "hardware")]
use std::time::Duration;

/// Something bytes can be written to and read from.
pub trait Port: Read + Write + Send {}
impl<T: Read + Write + Send> Port for T {}

/// Opens a serial port 8N1, no flow control, with `timeout` for every read and write (the
/// relay boards' and the orientation sensors' one way to open a port).
///
/// # Errors
///
/// serialport's, when the device cannot be opened or configured (missing, busy, no
/// permission).
#[cfg(feature = "hardware")]
pub fn open_8n1(
    path: &str,
    baud: u32,
    timeout: Duration,
) -> Result<Box<dyn serialport::SerialPort>, serialport::Error> {
    serialport::new(path, baud)
        .timeout(timeout)
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(serialport::FlowControl::None)
        .open()
}

/// Bytes as upper-case hex pairs separated by spaces: `A0 01 01 A2`.
pub fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02X}"))
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    #[test]
    fn hex_pairs_are_upper_case_and_spaced() {
        assert_eq!(super::hex(&[0xA0, 0x01, 0x0f]), "A0 01 0F");
        assert_eq!(super::hex(&[]), "");
    }
}
