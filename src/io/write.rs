//! Files that appear whole or not at all: images, checkpoints, shards and JSON reports
//! are written to a temporary file beside their path, flushed, and renamed over it.

use std::io::Write;
use std::path::{Path, PathBuf};

/// A file could not be written.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {path}: {reason}")]
pub struct WriteError {
    pub path: PathBuf,
    pub reason: String,
}

impl WriteError {
    fn new(path: &Path, reason: impl Into<String>) -> Self {
        WriteError {
            path: path.to_owned(),
            reason: reason.into(),
        }
    }
}

/// Checks before any work is done that `path` can be written: it is not a directory
/// and its directory accepts a new file. Nothing is left behind.
pub fn check_writable(path: &Path) -> Result<(), WriteError> {
    if path.is_dir() {
        return Err(WriteError::new(path, "it is a directory"));
    }
    tempfile::Builder::new()
        .prefix(".ember-check")
        .tempfile_in(parent_dir(path))
        .map(drop)
        .map_err(|e| WriteError::new(path, create_reason(path, &e)))
}

/// Why no file could be created beside `path`, in terms of the user's path: tempfile's
/// own message names the random temporary file, which means nothing to the user.
fn create_reason(path: &Path, e: &std::io::Error) -> String {
    let dir = parent_dir(path);
    match std::fs::metadata(dir) {
        Err(_) => format!("its directory {} does not exist", dir.display()),
        Ok(m) if !m.is_dir() => format!("{} is not a directory", dir.display()),
        Ok(_) => plain_reason(e),
    }
}

/// An I/O error's message without any path tempfile adds to it.
fn plain_reason(e: &std::io::Error) -> String {
    match e.raw_os_error() {
        Some(code) => std::io::Error::from_raw_os_error(code).to_string(),
        None => std::io::Error::from(e.kind()).to_string(),
    }
}

pub(super) fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Writes `bytes` to a temporary file beside `path`, flushes it to disk and renames it
/// over `path`: readers see the old file or the whole new one, never a part.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    let fail = |reason: String| WriteError::new(path, reason);
    let mut file = tempfile::Builder::new()
        .prefix(".ember-")
        .suffix(".tmp")
        .tempfile_in(parent_dir(path))
        .map_err(|e| fail(create_reason(path, &e)))?;
    file.as_file_mut()
        .write_all(bytes)
        .map_err(|e| fail(plain_reason(&e)))?;
    // tempfile creates files readable by their owner only; an image or checkpoint is an
    // ordinary file, so keep the mode of the file being replaced, or rw-r--r--.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(path).map_or(0o644, |m| m.permissions().mode() & 0o7777);
        file.as_file()
            .set_permissions(std::fs::Permissions::from_mode(mode))
            .map_err(|e| fail(e.to_string()))?;
    }
    file.as_file()
        .sync_all()
        .map_err(|e| fail(plain_reason(&e)))?;
    // On an error `file` is dropped, which deletes the temporary file.
    file.persist(path)
        .map_err(|e| fail(plain_reason(&e.error)))?;
    Ok(())
}
