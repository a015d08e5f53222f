//! `ember compare` and `ember info`.

use std::path::{Path, PathBuf};

use anyhow::{bail, Result};
use clap::Args;

use ember::embree::Device;
use ember::image::{self, Crop, Image};
use ember::scene::{load_obj_with, LoadOptions, SceneFile};

use super::scene_file::is_scene_file;

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

#[derive(Args)]
pub struct InfoArgs {
    /// An OBJ or a scene file (.toml): show what ember reads of it (triangles,
    /// materials, emitters, vertex colours) and its warnings, instead of the build.
    scene: Option<PathBuf>,
    /// With a scene: refuse it as `ember render --strict` would.
    #[arg(long, requires = "scene")]
    strict: bool,
}

pub fn info(args: InfoArgs) -> Result<()> {
    match &args.scene {
        Some(scene) => scene_info(
            scene,
            &LoadOptions {
                strict: args.strict,
            },
        ),
        None => build_info(),
    }
}

/// The scene as `ember render` loads it: the summary on stdout, each warning on stderr.
fn scene_info(path: &Path, options: &LoadOptions) -> Result<()> {
    let (scene, report) = if is_scene_file(path) {
        SceneFile::read(path)?.load_scene(options)?
    } else {
        load_obj_with(path, options)?
    };
    for warning in &report.warnings {
        eprintln!("warning: {warning}");
    }
    println!("{}: {}", path.display(), report.summary());
    let (lo, hi) = scene.bounds();
    println!(
        "{} vertices; bounds ({}, {}, {}) to ({}, {}, {})",
        report.vertices, lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
    );
    match report.vertex_colours {
        Some(colours) => println!(
            "vertex colours: written in {}, multiplying each material's diffuse colour",
            colours.range()
        ),
        None => println!("vertex colours: none"),
    }
    Ok(())
}

fn build_info() -> Result<()> {
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
