//! Files in and out. Every file ember reads is opened through [`InputFile`], which
//! refuses anything but a regular file before a byte is read; every file it writes
//! appears whole or not at all ([`write_atomically`]); and two paths are the same file
//! when [`same_file`] says so, whether or not the file exists yet.

mod identity;
mod read;
mod write;

pub use identity::{file_identity, same_file, FileIdentity};
pub use read::{InputFile, ReadError};
pub use write::{check_writable, write_atomically, WriteError};
