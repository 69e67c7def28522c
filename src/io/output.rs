//! Writing result files safely: to a temporary file beside the target, then renamed over it,
//! so that a reader (or a killed run) never sees a half-written file. Temporary names carry the
//! machine and the process (`.NAME.HOST-PID.tmp.EXT`), so runs sharing a folder (shards on a
//! shared disk) never touch each other's; only the temporaries of dead processes of this
//! machine are provably stale and removed.

use crate::error::{Error, Input, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// `s` made safe for a file name: ASCII letters, digits, `-` and `_` kept, every other
/// character `_` (so no `.` and no separator); `fallback` when empty.
pub fn file_safe(s: &str, fallback: &str) -> String {
    let t: String = s
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if t.is_empty() {
        fallback.into()
    } else {
        t
    }
}

/// This machine's name as it goes into temporary names (made [`file_safe`]).
pub fn host_tag() -> String {
    let raw = std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .or_else(|| std::env::var("HOSTNAME").ok())
        .or_else(|| std::env::var("COMPUTERNAME").ok())
        .unwrap_or_default();
    file_safe(raw.trim(), "host")
}

/// The temporary file for `target` written by process `pid` of machine `host`: hidden, next to
/// it, with the target's extension last (the PNG encoder picks its format by the extension).
pub fn temp_path_of(target: &Path, host: &str, pid: u32) -> PathBuf {
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let ext = target
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    target.with_file_name(format!(".{name}.{host}-{pid}.tmp{ext}"))
}

/// This process's temporary file for `target`.
pub(crate) fn temp_path(target: &Path) -> PathBuf {
    temp_path_of(target, &host_tag(), std::process::id())
}

/// The machine and process a temporary name (as made by [`temp_path_of`]) belongs to.
fn temp_owner(file_name: &str) -> Option<(&str, u32)> {
    let rest = file_name.strip_prefix('.')?;
    let (before, after) = rest.rsplit_once(".tmp")?;
    if !(after.is_empty() || (after.starts_with('.') && !after[1..].contains('.'))) {
        return None;
    }
    let (_, tag) = before.rsplit_once('.')?;
    let (host, pid) = tag.rsplit_once('-')?;
    Some((host, pid.parse().ok()?))
}

/// Whether process `pid` of this machine is gone, when that can be proved (Linux: no
/// `/proc/PID`); `false` when it is alive or cannot be told.
fn process_gone(pid: u32) -> bool {
    Path::new("/proc/self").exists() && !Path::new(&format!("/proc/{pid}")).exists()
}

/// Removes the temporary files in `dir` that are provably stale: made by a process of this
/// machine that has ended. Anything else (this process's, a live process's, another
/// machine's, a name not ours) is left alone. Returns the files removed.
pub fn remove_stale_temporaries(dir: &Path) -> Vec<PathBuf> {
    let (host, me) = (host_tag(), std::process::id());
    let mut removed = Vec::new();
    let Ok(rd) = std::fs::read_dir(dir) else {
        return removed;
    };
    for e in rd.flatten() {
        let n = e.file_name().to_string_lossy().into_owned();
        let stale =
            temp_owner(&n).is_some_and(|(h, pid)| h == host && pid != me && process_gone(pid));
        if stale && std::fs::remove_file(e.path()).is_ok() {
            removed.push(e.path());
        }
    }
    removed.sort();
    removed
}

/// Writes to `target` through `write` (which is given the temporary path), then renames the
/// temporary over the target; on failure the temporary is removed and `target` is left as it
/// was.
pub fn write_via_temp(
    target: &Path,
    write: impl FnOnce(&Path) -> std::result::Result<(), Error>,
) -> Result<()> {
    let tmp = temp_path(target);
    if let Err(e) = write(&tmp) {
        let _ = std::fs::remove_file(&tmp);
        return Err(e);
    }
    std::fs::rename(&tmp, target).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::io(target, e)
    })
}

/// Writes `bytes` to `path` atomically (temporary file in the same folder, then rename). A
/// path that names a device or a pipe (`--out /dev/null`, `--out /dev/stdout`) is written
/// through: renaming over it would replace the device with a file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    if let Ok(m) = std::fs::metadata(path) {
        if !m.is_file() && !m.is_dir() {
            let mut f = std::fs::OpenOptions::new()
                .write(true)
                .open(path)
                .map_err(|e| Error::io(path, e))?;
            return f.write_all(bytes).map_err(|e| Error::io(path, e));
        }
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    write_via_temp(path, |tmp| {
        (|| {
            let mut f = std::fs::File::create(tmp)?;
            f.write_all(bytes)?;
            f.sync_all()
        })()
        .map_err(|e| Error::io(path, e))
    })
}

/// Whether `a` and `b` name the same existing file: the same canonical path, or (on Unix) the
/// same device and inode (a hard link). A path that does not exist is no file's.
pub(crate) fn same_file(a: &Path, b: &Path) -> bool {
    let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) else {
        return false;
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if (ma.dev(), ma.ino()) == (mb.dev(), mb.ino()) {
            return true;
        }
    }
    let _ = (ma, mb);
    matches!(
        (std::fs::canonicalize(a), std::fs::canonicalize(b)),
        (Ok(x), Ok(y)) if x == y
    )
}

/// Refuses an output `out` (given as `--out`, or written into its folder) that is the same file
/// as one of `inputs`, the files the command reads: writing it would replace what was read.
/// Checked before anything is computed.
pub fn check_not_input<P: AsRef<Path>>(out: &Path, inputs: &[P]) -> Result<()> {
    match inputs.iter().find(|i| same_file(out, i.as_ref())) {
        None => Ok(()),
        Some(input) => Err(Error::Input {
            input: Input::Output,
            expected: format!(
                "a file that is not one of the command's inputs, got {}, the same file as {}",
                out.display(),
                input.as_ref().display()
            ),
        }),
    }
}

/// Sends a command's CSV where it goes: to `file` (atomically) when given, else alone to `out`
/// unless a JSON summary is asked for (which takes `out`). Returns where the summary goes:
/// `note` (standard error) when the CSV took `out`, else `out`; so that `cmd > file.csv` gives
/// a CSV file.
pub fn emit_csv<'a>(
    csv: &[u8],
    file: Option<&Path>,
    json: bool,
    out: &'a mut dyn Write,
    note: &'a mut dyn Write,
) -> Result<&'a mut dyn Write> {
    match file {
        Some(path) => write_atomic(path, csv)?,
        None if !json => {
            out.write_all(csv).map_err(|e| Error::io("<stdout>", e))?;
            return Ok(note);
        }
        None => {}
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pipe_is_written_through_never_replaced() {
        use std::io::Read;
        use std::os::unix::fs::FileTypeExt;
        let dir = tempfile::tempdir().expect("a temporary folder");
        let fifo = dir.path().join("pipe");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            eprintln!("skipped: mkfifo is not available");
            return;
        }
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || {
                let mut got = Vec::new();
                std::fs::File::open(&fifo)
                    .and_then(|mut f| f.read_to_end(&mut got))
                    .map(|_| got)
            })
        };
        write_atomic(&fifo, b"step,qx\n").expect("written through the pipe");
        // checked before joining: a replaced pipe would leave the reader waiting for ever
        let kind = std::fs::symlink_metadata(&fifo)
            .expect("still there")
            .file_type();
        assert!(kind.is_fifo(), "the pipe was replaced: {kind:?}");
        let got = reader.join().expect("the reader").expect("read");
        assert_eq!(got, b"step,qx\n");
    }

    #[test]
    fn temporary_names_say_whose_they_are() {
        let t = temp_path_of(Path::new("out/a.b.png"), "node-7", 4242);
        assert_eq!(t, Path::new("out/.a.b.png.node-7-4242.tmp.png"));
        let n = t.file_name().unwrap().to_str().unwrap();
        assert_eq!(temp_owner(n), Some(("node-7", 4242)));
        let t = temp_path_of(Path::new("summary"), "h", 1);
        assert_eq!(temp_owner(t.to_str().unwrap()), Some(("h", 1)));
        assert_eq!(temp_owner(".x.csv.tmp"), None);
        assert_eq!(temp_owner("a.csv"), None);
        assert!(!host_tag().contains('.'));
    }
}
