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
    super::check_distinct_files(
        &[("the output", &args.output)],
        &[("the input", &args.input)],
    )?;
    denoise::available()?;
    let start = Instant::now();
    let exr = OutputFormat::from_path(&args.output)? == OutputFormat::Exr;
    let size = LayeredImage::exr_size(&args.input)?;
    ember::limits::check_fits(
        &format!(
            "denoising {} (a {}x{} EXR)",
            args.input.display(),
            size.width,
            size.height
        ),
        memory_bytes(&size, exr),
    )
    .map_err(anyhow::Error::msg)?;
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
    if exr {
        let mut output = input;
        output.set(Layer::from_image(names::NOISY, names::RGB, &color));
        output.set(Layer::main(&denoised));
        output.write_exr(&args.output)?;
    } else {
        denoised.save_with(&args.output, &args.tone.into())?;
    }
    let seconds = start.elapsed().as_secs_f64();
    let peak = ember::limits::peak_resident_bytes();
    if super::verbosity::status() {
        eprintln!(
            "denoised {} ({}x{}, {}) into {} in {seconds:.2} s ({filter_seconds:.2} s in OIDN){}",
            args.input.display(),
            color.width,
            color.height,
            if aux.is_some() {
                "guided by albedo and normal"
            } else {
                "colour only"
            },
            args.output.display(),
            peak.map_or(String::new(), |bytes| format!(
                ", peak memory {}",
                ember::limits::human_bytes(bytes)
            )),
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
            // What the memory check before reading is measured against.
            "peak_resident_bytes": peak,
        }));
    }
    Ok(())
}

/// Bytes of memory denoising the EXR of `size` holds at its peak: reading it, the
/// denoiser with its images ([`denoise::memory_bytes`]), and an EXR output's channels
/// (the input's and the noisy image's) as samples and compressed.
fn memory_bytes(size: &ember::image::ExrSize, exr_output: bool) -> u64 {
    let pixels = u64::from(size.width) * u64::from(size.height);
    let output_channels = if exr_output { size.channels + 3 } else { 1 };
    size.read_bytes
        .saturating_add(denoise::memory_bytes(size.width, size.height))
        .saturating_add(pixels.saturating_mul(output_channels).saturating_mul(8))
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
