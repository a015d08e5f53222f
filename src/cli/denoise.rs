//! `ember denoise`: an EXR render denoised with Open Image Denoise, guided by its albedo
//! and normal layers.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{anyhow, bail, Result};
use clap::Args;

use ember::denoise;
use ember::image::layers::names;
use ember::image::{self, Image, Layer, LayeredImage, OutputFormat};

#[derive(Args)]
pub struct DenoiseArgs {
    /// A multi-layer EXR from `ember render --aov albedo,normal -o IN.exr`: the main
    /// image (R,G,B) and the layers `albedo` (R,G,B) and `normal` (X,Y,Z).
    input: PathBuf,
    /// The denoised image; the extension picks the format. EXR keeps the input's layers
    /// and the image before denoising as layer `noisy`; PNG and HDR hold the denoised
    /// image alone (PNG through --exposure and --tonemap, like `ember render`).
    #[arg(short, long)]
    output: PathBuf,
    /// Denoise the colour alone, for an EXR without albedo and normal layers (fine
    /// texture and edges come out softer).
    #[arg(long)]
    no_aux: bool,
    /// Print the summary as one JSON object on stdout, for scripts.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    tone: super::ToneArgs,
}

pub fn run(args: DenoiseArgs) -> Result<()> {
    image::check_output(&args.output)?;
    denoise::available()?;
    let start = Instant::now();
    let input = LayeredImage::read_exr(&args.input)?;
    let color = layer(&input, &args.input, names::MAIN, names::RGB)?;
    let aux = if args.no_aux {
        None
    } else {
        Some((
            layer(&input, &args.input, names::ALBEDO, names::RGB)?,
            layer(&input, &args.input, names::NORMAL, names::XYZ)?,
        ))
    };
    let filter_start = Instant::now();
    let denoised = denoise::denoise(&color, aux.as_ref().map(|(a, n)| (a, n)))
        .map_err(|e| anyhow!("{}: {e}", args.input.display()))?;
    let filter_seconds = filter_start.elapsed().as_secs_f64();
    if OutputFormat::from_path(&args.output)? == OutputFormat::Exr {
        let mut output = input;
        output.set(Layer::from_image(names::NOISY, names::RGB, &color));
        output.set(Layer::main(&denoised));
        output.write_exr(&args.output)?;
    } else {
        denoised.save_with(&args.output, &args.tone.into())?;
    }
    let seconds = start.elapsed().as_secs_f64();
    if super::verbosity::status() {
        eprintln!(
            "denoised {} ({}x{}, {}) into {} in {seconds:.2} s ({filter_seconds:.2} s in OIDN)",
            args.input.display(),
            color.width,
            color.height,
            if aux.is_some() {
                "guided by albedo and normal"
            } else {
                "colour only"
            },
            args.output.display(),
        );
    }
    if args.json {
        super::print_json(&serde_json::json!({
            "input": args.input.display().to_string(),
            "output": args.output.display().to_string(),
            "width": color.width,
            "height": color.height,
            "guided_by_albedo_and_normal": aux.is_some(),
            "seconds": seconds,
            "filter_seconds": filter_seconds,
        }));
    }
    Ok(())
}

/// The three-channel layer `name` of the input, or one line saying what is missing.
fn layer(input: &LayeredImage, path: &Path, name: &str, channels: [&str; 3]) -> Result<Image> {
    match input.image(name, channels) {
        Ok(image) => Ok(image),
        Err(e) if name == names::MAIN => {
            bail!("{}: {e}: the main image is its R,G,B channels", path.display())
        }
        Err(e) => bail!(
            "{}: {e}: render with --aov albedo,normal, or pass --no-aux to denoise the colour alone",
            path.display()
        ),
    }
}
