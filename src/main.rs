//! The `ember` command line: `ember render`, `ember merge`, `ember denoise`, `ember bench`,
//! `ember compare`, `ember info`.
//!
//! Environment variables (for tests and for running under a budget):
//! - `EMBER_MEMORY_LIMIT=BYTES`: memory ember may assume is available (default:
//!   `MemAvailable` from /proc/meminfo); scenes and images that need more are refused.
//! - `EMBER_EMBREE_CONFIG=STRING`: appended to the Embree device configuration.
//! - `EMBER_EMBREE_MEMORY_LIMIT=BYTES`: caps what Embree may allocate; a scene build
//!   that needs more fails with Embree's out-of-memory error.

// The binary's own printing macros, in place of `std`'s (which panic when the write
// fails): see `cli::console`. Defined before `mod cli` so that every module uses them.
macro_rules! println {
    () => { $crate::cli::console::write($crate::cli::console::Stream::Out, format_args!(""), true) };
    ($($arg:tt)*) => { $crate::cli::console::write($crate::cli::console::Stream::Out, format_args!($($arg)*), true) };
}
macro_rules! print {
    ($($arg:tt)*) => { $crate::cli::console::write($crate::cli::console::Stream::Out, format_args!($($arg)*), false) };
}
macro_rules! eprintln {
    () => { $crate::cli::console::write($crate::cli::console::Stream::Err, format_args!(""), true) };
    ($($arg:tt)*) => { $crate::cli::console::write($crate::cli::console::Stream::Err, format_args!($($arg)*), true) };
}
macro_rules! eprint {
    ($($arg:tt)*) => { $crate::cli::console::write($crate::cli::console::Stream::Err, format_args!($($arg)*), false) };
}

mod cli;

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use cli::{
    bench::BenchArgs,
    denoise::DenoiseArgs,
    merge::MergeArgs,
    misc::{CompareArgs, InfoArgs},
    render::RenderArgs,
    verbosity::Verbosity,
};

#[derive(Parser)]
#[command(
    name = "ember",
    version,
    about = "A physically based path tracer for OBJ scenes, on Intel Embree",
    arg_required_else_help = true,
    after_help = "`ember COMMAND -h` for a summary of a command's flags, `--help` for all of it.",
    after_long_help = EXAMPLES,
)]
struct Cli {
    /// Say less: warnings and errors only (no progress bar, no summary).
    #[arg(short, long, global = true, conflicts_with = "verbose")]
    quiet: bool,
    /// Say more: the details (the camera even when given, every material in `info`,
    /// the files a finished resume removed).
    #[arg(short, long, global = true)]
    verbose: bool,
    #[command(subcommand)]
    command: Command,
}

const EXAMPLES: &str = "\
Examples:
  ember render meshes/CornellBox-Original.obj -o cornell.png
  ember render scenes/cornell-box.toml --spp 256 --denoise -o box.png
  ember info meshes/CornellBox-Original.obj
  ember render scene.obj --spp 1024 --shard 0/4 -o part-0.ember   (then `ember merge part-*.ember -o out.exr`)
  ember bench meshes/CornellBox-Original.obj --plot bench.svg

The guide: docs/guide.md; every flag: docs/reference/cli.md.";

#[derive(Subcommand)]
enum Command {
    /// Render a mesh (OBJ, PLY) or a scene file (.toml) to PNG, EXR or HDR.
    ///
    /// PNG is 8-bit sRGB (tone-mapped); EXR and HDR hold linear radiance. Progressive:
    /// Ctrl-C writes the image so far and a checkpoint that --resume continues.
    Render(Box<RenderArgs>),
    /// Merge the shard files of a split render into one image.
    ///
    /// The shards come from `ember render --shard I/N`; they must be of one render and
    /// cover its samples, which is checked.
    Merge(MergeArgs),
    /// Denoise an EXR render with Intel Open Image Denoise.
    ///
    /// Guided by its albedo and normal layers (`ember render --aov albedo,normal`).
    Denoise(DenoiseArgs),
    /// Time Embree against the native BVH (builds, memory, Mrays/s).
    ///
    /// Build time, memory, and rays per second for primary, diffuse and shadow rays, on
    /// one thread and on several, side by side with the ratio to Embree's single rays.
    Bench(BenchArgs),
    /// Print MSE, relative MSE and PSNR of an image against a reference.
    ///
    /// EXR and HDR are read as linear, PNG as sRGB.
    Compare(CompareArgs),
    /// Show what ember reads of a scene, or the libraries it runs on.
    ///
    /// Given a scene: its triangles, materials, emitters and sky, textures, bounds, and
    /// the camera `ember render` would use, as flags. Without one: the Embree library in
    /// use, its ISA and threads, the Open Image Denoise library and device, and how
    /// ember was built.
    Info(InfoArgs),
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        // Help and version go to stdout; a mistake in the flags to stderr with clap's
        // usage line and its suggestions ("a similar argument exists"), exit status 2.
        Err(e) => return clap_exit(&e),
    };
    cli::verbosity::set(match (cli.quiet, cli.verbose) {
        (true, _) => Verbosity::Quiet,
        (_, true) => Verbosity::Verbose,
        _ => Verbosity::Normal,
    });
    let result = match cli.command {
        Command::Render(args) => {
            // A scene file's flags are read before the command line's (after `render`,
            // which only -q and -v may come before).
            let user: Vec<std::ffi::OsString> = std::env::args_os()
                .skip(1)
                .skip_while(|a| a != "render")
                .skip(1)
                .collect();
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
        // A scene file's flags are parsed by clap too: its errors keep clap's form.
        Err(e) => match e.downcast_ref::<clap::Error>() {
            Some(e) => clap_exit(e),
            None => {
                eprintln!("error: {e:#}");
                ExitCode::FAILURE
            }
        },
    }
}

/// Prints clap's own message for `e` (help, version, or a usage error) and gives its
/// exit status.
fn clap_exit(e: &clap::Error) -> ExitCode {
    let _ = e.print();
    ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2))
}
