//! `ember compare` and `ember info`.

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::Args;

use ember::embree::Device;
use ember::image::{self, Crop, Image};

#[derive(Args)]
pub struct CompareArgs {
    /// The image to judge.
    image: PathBuf,
    /// The reference it is compared with (relative MSE is relative to this one).
    reference: PathBuf,
    /// Compare only the pixels of this rectangle: left column, top row, width, height
    /// (row 0 at the top), e.g. a region near a light.
    #[arg(long, value_name = "X,Y,W,H")]
    crop: Option<Crop>,
    /// Average the image over blocks of N×N pixels first: a render at N times the
    /// reference's width and height is then judged as a render at the reference's size
    /// with N² times the samples
    #[arg(long, value_name = "N")]
    downsample: Option<u32>,
}

pub fn compare(args: CompareArgs) -> Result<()> {
    let mut image = Image::load(&args.image)?;
    let reference = Image::load(&args.reference)?;
    if let Some(factor) = args.downsample {
        image = image::downsampled(&image, factor).ok_or_else(|| {
            anyhow::anyhow!(
                "--downsample {factor}: it must divide the image's size, {}x{}",
                image.width,
                image.height
            )
        })?;
    }
    let error = match args.crop {
        None => image::compare(&image, &reference)?,
        Some(crop) => image::compare_crop(&image, &reference, crop)?,
    };
    println!(
        "MSE {:.6e}  relMSE {:.6e}  PSNR {:.2} dB",
        error.mse, error.rel_mse, error.psnr
    );
    Ok(())
}

pub fn info() -> Result<()> {
    let device = Device::new("")?;
    let info = device.info();
    let isa = match info.native_packet_width {
        16 => "AVX-512 (native 16-wide packets)",
        8 => "AVX/AVX2 (native 8-wide packets)",
        _ => "SSE (native 4-wide packets)",
    };
    println!("ember {}", env!("CARGO_PKG_VERSION"));
    println!(
        "embree: library {} (bindings generated from the {} headers in {})",
        info.version,
        info.header_version,
        env!("EMBER_EMBREE_INCLUDE")
    );
    println!("embree ISA: {isa}");
    println!(
        "embree threads: {} tasking, {} hardware threads",
        info.tasking_system,
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    match ember::denoise::available() {
        Ok(oidn) => println!(
            "denoiser: Open Image Denoise {} on its {} device ({})",
            oidn.version, oidn.device, oidn.library
        ),
        Err(e) => println!("denoiser: none: {e}"),
    }
    println!(
        "build: {} profile, target {}",
        if cfg!(debug_assertions) {
            "debug"
        } else {
            "release"
        },
        std::env::consts::ARCH
    );
    if info.version.is_empty() {
        bail!("Embree reported no version");
    }
    Ok(())
}
