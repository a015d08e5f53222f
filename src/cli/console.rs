//! Writing to standard output and standard error as Unix tools do. `std`'s `println!`
//! and `eprintln!` panic when the write fails (exit 101, a panic message nobody can
//! read); the binary's macros of the same names (defined in `main.rs`) come here
//! instead. A closed pipe (`ember info | head -1`) ends ember quietly, by `SIGPIPE`
//! as a C program would end; any other failure (a full disk, `/dev/full`) is one line
//! on standard error, where it can still be written, and exit status 1.

use std::fmt;
use std::io::{self, Write};

/// Which stream.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Stream {
    Out,
    Err,
}

/// Writes `args` (and a newline with `newline`) to `stream`, flushed, or ends the
/// process as the module documentation says.
pub fn write(stream: Stream, args: fmt::Arguments<'_>, newline: bool) {
    let written = match stream {
        Stream::Out => write_to(&mut io::stdout().lock(), args, newline),
        Stream::Err => write_to(&mut io::stderr().lock(), args, newline),
    };
    if let Err(e) = written {
        failed(stream, &e);
    }
}

fn write_to(out: &mut impl Write, args: fmt::Arguments<'_>, newline: bool) -> io::Result<()> {
    out.write_fmt(args)?;
    if newline {
        out.write_all(b"\n")?;
    }
    // Flushed now: at exit, `std` flushes standard output and drops any error.
    out.flush()
}

fn failed(stream: Stream, e: &io::Error) -> ! {
    if e.kind() == io::ErrorKind::BrokenPipe {
        // Whoever read the output has gone: end as the default SIGPIPE action does
        // (Rust ignores SIGPIPE, so the write returned an error instead).
        let _ = signal_hook::low_level::emulate_default_handler(signal_hook::consts::SIGPIPE);
        std::process::exit(128 + signal_hook::consts::SIGPIPE);
    }
    if stream == Stream::Out {
        let _ = writeln!(io::stderr(), "error: cannot write to standard output: {e}");
    }
    std::process::exit(1)
}
