//! Standard input read line by line on a thread of its own, for step mode's Enter and `q`.

use std::sync::mpsc::Receiver;

/// The longest line read from standard input in step mode, bytes: a longer one (standard
/// input redirected from a device or a binary file) ends the input, as its end does, so that
/// it is never gathered without bound.
const STDIN_LINE_MAX: u64 = 4096;

/// Spawns a thread that forwards standard input line by line (for step mode); it stops at the
/// end of the input, at a line that is not UTF-8 text and at one over `STDIN_LINE_MAX` (4096)
/// bytes.
pub fn stdin_lines() -> Receiver<String> {
    use std::io::{BufRead, Read};
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut stdin = std::io::stdin().lock();
        loop {
            let mut buf = Vec::new();
            match (&mut stdin)
                .take(STDIN_LINE_MAX)
                .read_until(b'\n', &mut buf)
            {
                Ok(0) | Err(_) => break,
                Ok(_) => {}
            }
            let ended = buf.last() == Some(&b'\n');
            if !ended && buf.len() as u64 == STDIN_LINE_MAX {
                break;
            }
            let Ok(line) = String::from_utf8(buf) else {
                break;
            };
            let line = line.strip_suffix('\n').unwrap_or(&line);
            let line = line.strip_suffix('\r').unwrap_or(line);
            if tx.send(line.to_string()).is_err() {
                break;
            }
        }
    });
    rx
}
