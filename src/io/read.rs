//! Opening a file to read: the one way every reader of ember (OBJ, MTL, textures,
//! environment maps, scene files, shards, checkpoints, EXRs) gets at its bytes.
//!
//! Only a regular file is read. A named pipe would block the open until some writer
//! came, and a device such as `/dev/zero` has no end: both are refused by their kind
//! before a byte is read, and the open itself never waits (`O_NONBLOCK`). The length
//! is known before reading, so a reader can check what the file will cost in memory
//! first, and reads no more than that length.

use std::fs::{File, Metadata};
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};

/// A file could not be read, or is not something ember reads.
#[derive(Debug, thiserror::Error)]
#[error("cannot read {path}: {reason}")]
pub struct ReadError {
    pub path: PathBuf,
    pub reason: String,
}

impl ReadError {
    pub fn new(path: &Path, reason: impl Into<String>) -> Self {
        ReadError {
            path: path.to_owned(),
            reason: reason.into(),
        }
    }
}

/// A regular file opened for reading, and its length.
#[derive(Debug)]
pub struct InputFile {
    path: PathBuf,
    file: File,
    len: u64,
}

impl InputFile {
    /// Opens `path` for reading. Refuses, with the reason, what is not a regular file:
    /// a directory, a named pipe (FIFO), a character or block device, a socket.
    pub fn open(path: &Path) -> Result<InputFile, ReadError> {
        let fail = |reason: String| ReadError::new(path, reason);
        // Classified before the open: opening a FIFO or a socket could wait or fail
        // with a reason that names neither.
        let meta = std::fs::metadata(path).map_err(|e| fail(e.to_string()))?;
        not_regular(&meta).map_or(Ok(()), |kind| Err(fail(kind)))?;
        let file = open_nonblocking(path).map_err(|e| fail(e.to_string()))?;
        // Again on what was opened: the path may have been replaced meanwhile.
        let meta = file.metadata().map_err(|e| fail(e.to_string()))?;
        not_regular(&meta).map_or(Ok(()), |kind| Err(fail(kind)))?;
        Ok(InputFile {
            path: path.to_owned(),
            file,
            len: meta.len(),
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The file's length in bytes, as it was when opened.
    pub fn len(&self) -> u64 {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The open file, for positioned reads within [`len`](Self::len).
    pub fn file(&self) -> &File {
        &self.file
    }

    /// The file's `len` bytes; an error if it changed length while being read.
    pub fn read_all(self) -> Result<Vec<u8>, ReadError> {
        let len = usize::try_from(self.len)
            .map_err(|_| ReadError::new(&self.path, "it is too large to read"))?;
        let mut bytes = Vec::with_capacity(len);
        let file = &self.file;
        file.take(self.len)
            .read_to_end(&mut bytes)
            .map_err(|e| ReadError::new(&self.path, e.to_string()))?;
        self.check_length(bytes.len() as u64)?;
        Ok(bytes)
    }

    /// Checks, after `read` bytes were read, that the file still ends at its length.
    pub fn check_length(&self, read: u64) -> Result<(), ReadError> {
        let mut file = &self.file;
        let grew = matches!(file.read(&mut [0]), Ok(n) if n > 0);
        if read < self.len {
            Err(ReadError::new(
                &self.path,
                "it became shorter while being read",
            ))
        } else if grew {
            Err(ReadError::new(&self.path, "it grew while being read"))
        } else {
            Ok(())
        }
    }

    /// The open file, for a reader that bounds itself by [`len`](Self::len).
    pub fn into_file(self) -> File {
        self.file
    }

    /// A buffered reader of the file, for decoders that read what their headers
    /// announce (and seek): [`len`](Self::len) bounds what they may need.
    pub fn into_reader(self) -> BufReader<File> {
        BufReader::new(self.file)
    }
}

/// What the file is when it is not a regular file, as the reason to refuse it.
fn not_regular(meta: &Metadata) -> Option<String> {
    let kind = meta.file_type();
    if kind.is_file() {
        return None;
    }
    let what = if kind.is_dir() {
        "a directory"
    } else {
        special_kind(&kind)
    };
    Some(format!("it is {what}, not a regular file"))
}

#[cfg(unix)]
fn special_kind(kind: &std::fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if kind.is_fifo() {
        "a named pipe (FIFO)"
    } else if kind.is_char_device() {
        "a character device"
    } else if kind.is_block_device() {
        "a block device"
    } else if kind.is_socket() {
        "a socket"
    } else {
        "not a file"
    }
}

#[cfg(not(unix))]
fn special_kind(_: &std::fs::FileType) -> &'static str {
    "not a file"
}

/// Opens for reading without waiting: a FIFO swapped in after the check opens at once
/// (and is then refused) instead of blocking until a writer comes.
#[cfg(unix)]
fn open_nonblocking(path: &Path) -> std::io::Result<File> {
    use std::os::unix::fs::OpenOptionsExt;
    std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)
}

#[cfg(not(unix))]
fn open_nonblocking(path: &Path) -> std::io::Result<File> {
    File::open(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regular_files_are_read_to_their_length() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.txt");
        std::fs::write(&path, b"hello").unwrap();
        let file = InputFile::open(&path).unwrap();
        assert_eq!(file.len(), 5);
        assert_eq!(file.read_all().unwrap(), b"hello");
        let mut text = String::new();
        InputFile::open(&path)
            .unwrap()
            .into_reader()
            .read_to_string(&mut text)
            .unwrap();
        assert_eq!(text, "hello");
    }

    #[test]
    fn what_is_not_a_regular_file_is_refused_by_its_kind() {
        let dir = tempfile::tempdir().unwrap();
        let e = InputFile::open(dir.path()).unwrap_err();
        assert!(e
            .to_string()
            .ends_with("it is a directory, not a regular file"));
        let e = InputFile::open(Path::new("/dev/zero")).unwrap_err();
        assert!(e.reason.contains("character device"), "{e}");
        let e = InputFile::open(&dir.path().join("none")).unwrap_err();
        assert!(e.to_string().contains("none"), "{e}");
        let fifo = dir.path().join("fifo");
        let made = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap();
        assert!(made.success());
        let e = InputFile::open(&fifo).unwrap_err();
        assert!(e.reason.contains("named pipe"), "{e}");
    }
}
