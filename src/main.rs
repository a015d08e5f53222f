//! The `ember` command line: `ember render`, `ember merge`, `ember denoise`, `ember bench`,
//! `ember compare`, `ember info`.
//!
//! Environment variables (for tests and for running under a budget):
//! - `EMBER_MEMORY_LIMIT=BYTES`: memory ember may assume is available (default:
//!   `MemAvailable` from /proc/meminfo); scenes and images that need more are refused.
//! - `EMBER_EMBREE_CONFIG=STRING`: appended to the Embree device configuration.
//! - `EMBER_EMBREE_MEMORY_LIMIT=BYTES`: caps what Embree may allocate; a scene build
//!   that needs more fails with Embree's out-of-memory error.

mod cli;

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use cli::{
    bench::BenchArgs,
    denoise::DenoiseArgs,
    merge::MergeArgs,
    misc::{CompareArgs, InfoArgs},
    render::RenderArgs,
};

#[derive(Parser)]
#[command(
    name = "ember",
    version,
    about = "A physically based path tracer for OBJ scenes, on Intel Embree"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render an OBJ scene or a scene file (.toml) to PNG (sRGB), EXR or HDR (linear).
    Render(Box<RenderArgs>),
    /// Merge the shard files of a split render (`render --shard I/N`) into one image.
    Merge(MergeArgs),
    /// Denoise an EXR render with Intel Open Image Denoise, guided by its albedo and
    /// normal layers (`ember render --aov albedo,normal`).
    Denoise(DenoiseArgs),
    /// Time Embree against the native BVH: build time, memory, and rays per second for
    /// primary, diffuse and shadow rays, single-threaded and on several threads.
    Bench(BenchArgs),
    /// Print MSE, relative MSE and PSNR of an image against a reference (EXR, HDR or PNG).
    Compare(CompareArgs),
    /// Show the Embree library in use, its ISA and threads, the Open Image Denoise
    /// library and device, and how ember was built; or, given a scene, what ember reads
    /// of it.
    Info(InfoArgs),
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            // --help and --version go to stdout in full.
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            // One line: clap's first line says what is wrong with which flag, or ends
            // in a colon before the list of what is missing, which is joined to it.
            let text = e.render().to_string();
            let mut lines = text.lines().map(str::trim).filter(|l| !l.is_empty());
            let first = lines.next().unwrap_or("error: invalid arguments");
            match lines.next() {
                Some(what) if first.ends_with(':') => eprintln!("{first} {what}"),
                _ => eprintln!("{first}"),
            }
            return ExitCode::from(2);
        }
    };
    let result = match cli.command {
        Command::Render(args) => {
            // A scene file's flags are read before the command line's (after `render`).
            let user: Vec<std::ffi::OsString> = std::env::args_os().skip(2).collect();
            cli::render::run(*args, &user)
        }
        Command::Merge(args) => cli::merge::run(args),
        Command::Denoise(args) => cli::denoise::run(args).map(|()| ExitCode::SUCCESS),
        Command::Bench(args) => cli::bench::run(args).map(|()| ExitCode::SUCCESS),
        Command::Compare(args) => cli::misc::compare(args).map(|()| ExitCode::SUCCESS),
        Command::Info(args) => cli::misc::info(args).map(|()| ExitCode::SUCCESS),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
