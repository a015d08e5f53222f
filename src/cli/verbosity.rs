//! How much ember says on standard error: `-q` keeps warnings and errors only, `-v`
//! adds the details of what was chosen and how long each stage took. Set once from the
//! command line, before any command runs; read wherever a status line is printed.

use std::sync::atomic::{AtomicU8, Ordering};

/// How much to say.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Verbosity {
    /// Warnings and errors only: no progress bar, no status or summary lines.
    Quiet = 0,
    /// Status lines, the progress bar on a terminal, and the summary.
    Normal = 1,
    /// Also the details: every setting chosen for the user, each stage's time.
    Verbose = 2,
}

static LEVEL: AtomicU8 = AtomicU8::new(Verbosity::Normal as u8);

/// Sets the level for the rest of the process (`main`, from `-q`/`-v`).
pub fn set(level: Verbosity) {
    LEVEL.store(level as u8, Ordering::Relaxed);
}

fn level() -> Verbosity {
    match LEVEL.load(Ordering::Relaxed) {
        0 => Verbosity::Quiet,
        1 => Verbosity::Normal,
        _ => Verbosity::Verbose,
    }
}

/// Whether status lines and progress bars are shown (not `-q`).
pub fn status() -> bool {
    level() >= Verbosity::Normal
}

/// Whether details are shown (`-v`).
pub fn verbose() -> bool {
    level() >= Verbosity::Verbose
}

/// Most warnings of one load printed without `-v`: a downloaded scene that lacks its
/// texture folder says one line per material and slot, which would bury the rest.
pub const WARNINGS_SHOWN: usize = 20;

/// Prints a load's warnings on standard error: every one with `-v`, otherwise the first
/// [`WARNINGS_SHOWN`] and how many more there are.
pub fn print_warnings(warnings: &[String]) {
    let shown = if verbose() {
        warnings.len()
    } else {
        WARNINGS_SHOWN
    };
    for warning in warnings.iter().take(shown) {
        eprintln!("warning: {warning}");
    }
    if warnings.len() > shown {
        let more = warnings.len() - shown;
        eprintln!("warning: {more} more warnings like these (-v prints every one)");
    }
}
