//! The one way an input file is read (scenarios, point and torque tables, plans, waypoints,
//! sets, simulate results, relay maps, replay logs, a batch's own files): only a regular file
//! is read, and at most [`MAX_INPUT_BYTES`] of it, so that a device, a pipe or a huge file
//! named by mistake (`/dev/zero`) is refused with a clear error instead of being read for ever.
//! Serial ports (`--port`, `--sensor`) are devices by design and are not read through here.

use crate::error::{Error, Result};
use std::io::Read;
use std::path::Path;

/// The largest input file read, in bytes (256 MiB): far above any scenario, plan or sweep
/// this program writes or reads, and small enough that a file named by mistake cannot
/// exhaust the memory.
pub const MAX_INPUT_BYTES: u64 = 256 * 1024 * 1024;

/// Why a path is not read as an input file (carried inside a [`std::io::Error`], so that each
/// caller words it as it words any other reading error, after the file's name).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum InputFileError {
    /// The path names something else than a regular file (a device, a pipe, a folder...).
    #[error("expected a regular file, got {0}")]
    NotRegular(&'static str),
    /// The file is larger than [`MAX_INPUT_BYTES`].
    #[error("expected a file of at most {} MiB, got more", MAX_INPUT_BYTES >> 20)]
    TooLarge,
}

impl From<InputFileError> for std::io::Error {
    fn from(e: InputFileError) -> Self {
        std::io::Error::new(std::io::ErrorKind::InvalidInput, e)
    }
}

/// What a file type is, as an error names it.
fn kind_name(t: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_fifo() {
            return "a pipe (FIFO)";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() {
        "a folder"
    } else {
        "something else than a file"
    }
}

/// An error unless `t` is a regular file's type.
fn regular(t: std::fs::FileType) -> std::io::Result<()> {
    match t.is_file() {
        true => Ok(()),
        false => Err(InputFileError::NotRegular(kind_name(t)).into()),
    }
}

/// The bytes of the input file at `path` (symbolic links followed).
///
/// # Errors
/// The path cannot be opened or read, is not a regular file ([`InputFileError::NotRegular`],
/// checked before opening, so that a pipe is never waited on), or holds more than
/// [`MAX_INPUT_BYTES`] ([`InputFileError::TooLarge`]; no more than that is read).
pub fn read_bytes(path: &Path) -> std::io::Result<Vec<u8>> {
    regular(std::fs::metadata(path)?.file_type())?;
    let file = std::fs::File::open(path)?;
    // checked again on what was opened, in case the path was replaced in between
    let meta = file.metadata()?;
    regular(meta.file_type())?;
    if meta.len() > MAX_INPUT_BYTES {
        return Err(InputFileError::TooLarge.into());
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.take(MAX_INPUT_BYTES + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > MAX_INPUT_BYTES {
        return Err(InputFileError::TooLarge.into());
    }
    Ok(bytes)
}

/// [`read_bytes`] as UTF-8 text.
///
/// # Errors
/// Those of [`read_bytes`], and bytes that are not UTF-8 ([`std::io::ErrorKind::InvalidData`]).
pub fn read_text(path: &Path) -> std::io::Result<String> {
    String::from_utf8(read_bytes(path)?)
        .map_err(|_| std::io::Error::new(std::io::ErrorKind::InvalidData, "expected UTF-8 text"))
}

/// [`read_text`], its error an [`Error::Io`] naming the file.
pub fn text(path: &Path) -> Result<String> {
    read_text(path).map_err(|e| Error::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_and_folders_are_refused_by_their_kind() {
        let e = read_text(Path::new("/dev/zero")).unwrap_err();
        assert_eq!(
            e.to_string(),
            "expected a regular file, got a character device"
        );
        let dir = tempfile::tempdir().unwrap();
        let e = text(dir.path()).unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "{}: expected a regular file, got a folder",
                dir.path().display()
            )
        );
    }

    #[test]
    fn a_regular_file_is_read_whole_and_bad_text_named() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.csv");
        std::fs::write(&p, "x,y,z\n").unwrap();
        assert_eq!(text(&p).unwrap(), "x,y,z\n");
        std::fs::write(&p, b"x\xff\n").unwrap();
        assert_eq!(
            read_text(&p).unwrap_err().to_string(),
            "expected UTF-8 text"
        );
        assert_eq!(read_bytes(&p).unwrap(), b"x\xff\n");
    }

    #[test]
    fn a_file_over_the_cap_is_refused_without_reading_it() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("big.csv");
        let f = std::fs::File::create(&p).unwrap();
        f.set_len(MAX_INPUT_BYTES + 1).unwrap(); // sparse: nothing written
        assert_eq!(
            read_bytes(&p).unwrap_err().to_string(),
            "expected a file of at most 256 MiB, got more"
        );
        f.set_len(3).unwrap();
        assert_eq!(read_bytes(&p).unwrap(), vec![0u8; 3]);
    }
}
