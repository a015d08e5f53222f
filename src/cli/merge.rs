//! `ember merge`: shards of a split render into one image.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::Ordering;
use std::time::Instant;

use anyhow::Result;
use clap::Args;

use ember::film::aov::Aov;
use ember::film::merge;
use ember::film::output::FilmOutput;

#[derive(Args)]
pub struct MergeArgs {
    /// The shard files (`ember render --shard I/N -o FILE`), in any order.
    #[arg(required = true)]
    shards: Vec<PathBuf>,
    /// The merged image; the extension picks the format: .png, .exr or .hdr.
    #[arg(short, long)]
    output: PathBuf,
    /// Merge the shards that are there even if sample ranges are missing or shards are
    /// incomplete: every pixel is then the mean of the samples present (still unbiased,
    /// only noisier). The missing ranges are listed.
    #[arg(long)]
    allow_partial: bool,
    /// Render passes to add to an .exr output as layers (as `ember render --aov`).
    #[arg(long, value_name = "PASSES", value_delimiter = ',', value_parser = super::parse_aov)]
    aov: Vec<Aov>,
    /// Denoise the merged image with Intel Open Image Denoise (as `ember render --denoise`).
    #[arg(long)]
    denoise: bool,
    /// Print the summary as one JSON object on stdout, for scripts.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    tone: super::ToneArgs,
}

pub fn run(args: MergeArgs) -> Result<ExitCode> {
    super::check_image_output(&args.output, &args.aov, args.denoise)?;
    let shards: Vec<(&str, &std::path::Path)> = args
        .shards
        .iter()
        .map(|p| ("the shard", p.as_path()))
        .collect();
    super::check_distinct_files(&[("the merged image", &args.output)], &shards)?;
    let start = Instant::now();
    let (film, report) = merge::merge(&args.shards, args.allow_partial)?;
    let output = FilmOutput {
        aovs: &args.aov,
        denoise: args.denoise,
        tonemap: &args.tone.into(),
    };
    // A signal now would cut the write short and leave its temporary file: it waits.
    let stop = super::stop_on_signals()?;
    output.write(&film, &args.output)?;
    // After the write, which refuses a film with a pixel no shard sampled.
    for range in &report.missing {
        eprintln!(
            "warning: no shard holds samples {}..{} of 0..{}: the image has fewer samples",
            range.start, range.end, film.samples.end
        );
    }
    for path in &report.incomplete {
        eprintln!(
            "warning: {} is incomplete: merged what it has",
            path.display()
        );
    }
    let seconds = start.elapsed().as_secs_f64();
    if super::verbosity::status() {
        eprintln!(
            "merged {} shards ({}x{}, {} spp) into {} in {seconds:.2} s",
            args.shards.len(),
            film.width,
            film.height,
            film.samples.end,
            args.output.display(),
        );
    }
    let signal = stop.load(Ordering::SeqCst);
    if signal != 0 {
        eprintln!(
            "interrupted by {} while writing {}: it was completed first",
            super::signal_name(signal),
            args.output.display()
        );
    }
    if args.json {
        let path = |p: &std::path::Path| p.display().to_string();
        super::print_json(&serde_json::json!({
            "output": path(&args.output),
            "shards": args.shards.iter().map(|p| path(p)).collect::<Vec<_>>(),
            "width": film.width,
            "height": film.height,
            "spp": film.samples.end,
            "missing_samples": report.missing.iter().map(|r| [r.start, r.end]).collect::<Vec<_>>(),
            "incomplete_shards": report.incomplete.iter().map(|p| path(p)).collect::<Vec<_>>(),
            "seconds": seconds,
        }));
    }
    match signal {
        0 => Ok(ExitCode::SUCCESS),
        signal => Ok(ExitCode::from((128 + signal).min(255) as u8)),
    }
}
