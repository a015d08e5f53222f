//! `ember compare` and `ember info`.

use std::path::{Path, PathBuf};

use anyhow::{bail, Result};
use clap::Args;

use ember::embree::Device;
use ember::image::{self, Crop, Image};
use glam::Vec3;

use super::render::LoadedScene;
use ember::scene::{
    Filter, LoadOptions, Material, Model, Sampler, Scene, SceneLight, Texels, Wrap,
};

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
    /// Print the figures as one JSON object on stdout, for scripts.
    #[arg(long)]
    json: bool,
}

pub fn compare(args: CompareArgs) -> Result<()> {
    let (mut image, reference) = Image::load_pair(&args.image, &args.reference)?;
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
    if args.json {
        super::print_json(&serde_json::json!({
            "image": args.image.display().to_string(),
            "reference": args.reference.display().to_string(),
            "width": reference.width,
            "height": reference.height,
            "crop": args.crop.map(|c| [c.x, c.y, c.width, c.height]),
            "downsample": args.downsample,
            "mse": error.mse,
            "rel_mse": error.rel_mse,
            // Infinite for identical images, which JSON cannot hold: null then.
            "psnr": error.psnr.is_finite().then_some(error.psnr),
        }));
    } else {
        println!(
            "MSE {:.6e}  relMSE {:.6e}  PSNR {:.2} dB",
            error.mse, error.rel_mse, error.psnr
        );
    }
    Ok(())
}

#[derive(Args)]
pub struct InfoArgs {
    /// A mesh (.obj, .ply) or a scene file (.toml) to describe, instead of the build.
    ///
    /// What `ember render SCENE` would read of it: triangles, materials, emitters and
    /// sky, textures, bounds, vertex colours, the camera as flags, and its warnings.
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

/// The scene as `ember render SCENE` loads it, on stdout (each warning on stderr):
/// its triangles, materials, emitters and sky, textures, bounds, and the camera ember
/// would use, as flags.
fn scene_info(path: &Path, options: &LoadOptions) -> Result<()> {
    let loaded = super::render::load_as_rendered(path, options.strict)?;
    let (scene, report) = (&loaded.scene, &loaded.report);
    super::verbosity::print_warnings(&report.warnings);
    println!("{}: {}", path.display(), report.summary());
    let placed = scene
        .instancing
        .as_ref()
        .map_or(String::new(), |instancing| {
            format!(
                "; {} placements put {} triangles in the world",
                instancing.instances.len(),
                instancing.placed_triangles()
            )
        });
    let dropped = match report.degenerate_dropped {
        0 => String::new(),
        n => format!(", {n} degenerate dropped"),
    };
    println!(
        "triangles: {} ({} vertices{dropped}){placed}",
        report.triangles, report.vertices
    );
    for line in &loaded.contents {
        println!("{line}");
    }
    print_materials(scene);
    print_lights(&loaded);
    print_placed_lights(&loaded.placed_lights);
    print_textures(scene);
    let (lo, hi) = scene.bounds();
    let size = hi - lo;
    println!(
        "bounds: ({}, {}, {}) to ({}, {}, {}), size {} x {} x {}",
        lo.x, lo.y, lo.z, hi.x, hi.y, hi.z, size.x, size.y, size.z
    );
    let how = match (&loaded.file_camera, loaded.automatic_camera) {
        (Some(name), _) => format!("the file's camera {name:?}"),
        (None, true) => "automatic, framing the bounds from +z".to_owned(),
        (None, false) => "the scene file's".to_owned(),
    };
    let (width, height) = loaded.size;
    println!(
        "camera ({how}): {} --width {width} --height {height}",
        super::render::camera_flags(&loaded.camera_settings)
    );
    if let Some(note) = &loaded.size_note {
        println!("note: {note}");
    }
    print_file_cameras(&loaded.file_cameras);
    match report.vertex_colours {
        Some(colours) => println!(
            "vertex colours: written in {}, multiplying each material's diffuse colour",
            colours.range()
        ),
        None => println!("vertex colours: none"),
    }
    Ok(())
}

/// How many materials to list before "and N more" (all with `-v`).
const MATERIALS_LISTED: usize = 40;

/// Each material with its model, its maps, whether it emits, and its triangles.
fn print_materials(scene: &Scene) {
    let mut triangles = vec![0usize; scene.materials.len()];
    for &m in &scene.mesh.material {
        if let Some(count) = triangles.get_mut(m as usize) {
            *count += 1;
        }
    }
    println!("materials: {}", scene.materials.len());
    let shown = match super::verbosity::verbose() {
        true => scene.materials.len(),
        false => MATERIALS_LISTED,
    };
    // The grey stand-in for faces without a material is listed only when used.
    let listed = scene.materials.iter().zip(&triangles);
    for (m, count) in listed
        .filter(|(m, &n)| n > 0 || m.name != "default")
        .take(shown)
    {
        println!("  {:?}: {}; {count} triangles", m.name, describe(m));
    }
    if scene.materials.len() > shown {
        println!(
            "  ... and {} more (-v lists all)",
            scene.materials.len() - shown
        );
    }
}

/// `GGX conductor (alpha 0.1), Ks (0.9,0.9,0.9), maps map_Kd, bump, emits Ke (17,12,4)`.
fn describe(m: &Material) -> String {
    let rgb = |v: Vec3| format!("({},{},{})", v.x, v.y, v.z);
    let mut s = match m.model {
        Model::Lambert => format!("Lambert, Kd {}", rgb(m.diffuse)),
        Model::Conductor { alpha } => {
            format!("GGX conductor (alpha {alpha}), Ks {}", rgb(m.specular))
        }
        Model::Coated { alpha } => format!(
            "Lambert under a GGX coat (alpha {alpha}), Kd {}, Ks {}",
            rgb(m.diffuse),
            rgb(m.specular)
        ),
        Model::Glass { ior } => format!("smooth glass, index {ior}"),
        Model::MetallicRoughness {
            alpha,
            ior,
            specular,
            transmission,
        } => {
            let mut s = format!(
                "glTF metallic-roughness, base colour {}, metallic {}, roughness {} (alpha {alpha})",
                rgb(m.diffuse),
                m.metallic,
                m.roughness.unwrap_or(alpha.sqrt()),
            );
            if ior != 1.5 {
                s += &format!(", ior {ior}");
            }
            if specular != 1.0 || m.specular != Vec3::ONE {
                s += &format!(", specular {specular} colour {}", rgb(m.specular));
            }
            if transmission > 0.0 {
                s += &format!(", transmission {transmission}");
            }
            s
        }
    };
    let maps = &m.maps;
    // glTF's names for a glTF material's maps (one texture may feed two slots).
    let gltf = m.factors_multiply_maps();
    let name = |mtl: &'static str, gltf_name: &'static str| if gltf { gltf_name } else { mtl };
    let named = [
        (m.diffuse_texture, name("map_Kd", "baseColorTexture")),
        (maps.specular, name("map_Ks", "specularColorTexture")),
        (maps.emission, name("map_Ke", "emissiveTexture")),
        (maps.shininess, "map_Ns"),
        (maps.roughness, name("map_Pr", "metallicRoughnessTexture")),
        (maps.metallic, name("map_Pm", "metallicRoughnessTexture")),
        (maps.transmission, "transmissionTexture"),
        (maps.bump, "bump"),
        (maps.normal, name("norm", "normalTexture")),
        (m.opacity_map, name("map_d", "alpha")),
    ];
    let mut present: Vec<&str> = named
        .iter()
        .filter(|(t, _)| t.is_some())
        .map(|(_, n)| *n)
        .collect();
    present.dedup();
    if !present.is_empty() {
        s += &format!(", maps {}", present.join(" "));
    }
    if m.metallic > 0.0 && !m.factors_multiply_maps() {
        s += &format!(", metallic {}", m.metallic);
    }
    if m.opacity < 1.0 {
        s += &format!(", opacity {}", m.opacity);
    }
    if m.is_emissive() {
        s += &format!(", emits Ke {}", rgb(m.emission));
        if m.two_sided_emission {
            s += " from both faces";
        }
    }
    s
}

/// The lights: emissive triangles by material, with their area and power, and the sky.
fn print_lights(loaded: &LoadedScene) {
    let scene = &loaded.scene;
    let lights = scene.light_mesh();
    // Per emitting material: triangles, area, and power (π · area · luminance of Ke,
    // the flux of each emitting face of a diffuse emitter; a map_Ke scales it further).
    let mut by_material: Vec<(u32, usize, f64, f64)> = Vec::new();
    for &t in &scene.emitters {
        let [a, b, c] = lights.vertices(t);
        let area = 0.5 * f64::from((b - a).cross(c - a).length());
        let m = lights.material[t as usize];
        let material = &scene.materials[m as usize];
        let luminance = f64::from(material.emission.dot(Vec3::new(0.2126, 0.7152, 0.0722)));
        let faces = f64::from(material.emitting_faces());
        let power = std::f64::consts::PI * area * luminance * faces;
        match by_material.iter_mut().find(|e| e.0 == m) {
            Some(e) => (e.1, e.2, e.3) = (e.1 + 1, e.2 + area, e.3 + power),
            None => by_material.push((m, 1, area, power)),
        }
    }
    println!(
        "emitters: {} emissive triangles in {} material{}",
        scene.emitters.len(),
        by_material.len(),
        if by_material.len() == 1 { "" } else { "s" }
    );
    for (m, count, area, power) in &by_material {
        let material = &scene.materials[*m as usize];
        let faces = match material.two_sided_emission {
            true => " x 2 faces",
            false => "",
        };
        println!(
            "  {:?}: {count} triangles, area {area:.4}, power {power:.4} (pi x area x luminance of Ke{faces})",
            material.name
        );
    }
    println!("sky: {}", loaded.sky);
}

/// The cameras a model file places (a glTF's), one line each, when it has any.
fn print_file_cameras(cameras: &[ember::scene::FileCamera]) {
    if cameras.is_empty() {
        return;
    }
    println!("cameras: {} (--camera NAME or index from 0)", cameras.len());
    for (i, camera) in cameras.iter().enumerate() {
        let flags = super::render::camera_flags(&camera.settings);
        let mesh = camera
            .mesh
            .as_ref()
            .map_or(String::new(), |m| format!(" of [[mesh]] {m:?}"));
        let aspect = camera
            .aspect
            .map_or(String::new(), |a| format!(", aspect ratio {a}"));
        println!("  {i} {:?}{mesh}: {flags}{aspect}", camera.name);
    }
}

/// The lights a scene file places, one line each.
pub fn print_placed_lights(lights: &[SceneLight]) {
    println!("placed lights: {}", lights.len());
    for (i, light) in lights.iter().enumerate() {
        println!("  {}: {}", light.label(i), light.describe());
    }
}

/// The textures: how many, their sizes and what they hold in memory.
fn print_textures(scene: &Scene) {
    let mut bytes = 0;
    let mut sizes = Vec::new();
    for t in &scene.textures {
        let (kind, held) = match &t.texels {
            Texels::Srgb8(v) => ("8-bit sRGB", v.len()),
            Texels::Rgb8(v) => ("8-bit linear RGB", v.len()),
            Texels::Gray8(v) => ("8-bit grey", v.len()),
            Texels::RgbF32(v) => ("float RGB", 12 * v.len()),
            Texels::GrayF32(v) => ("float grey", 4 * v.len()),
        };
        bytes += held;
        let sampler = sampler_words(t.sampler);
        sizes.push(format!("{}x{} {kind}{sampler}", t.width, t.height));
    }
    match sizes.is_empty() {
        true => println!("textures: none"),
        false => println!(
            "textures: {} ({}), {}",
            sizes.len(),
            ember::limits::human_bytes(bytes as u64),
            sizes.join(", ")
        ),
    }
}

/// A texture's sampler in words, ` (clamp, nearest)`, when it is not the default
/// (repeating, bilinear).
fn sampler_words(sampler: Sampler) -> String {
    if sampler == Sampler::default() {
        return String::new();
    }
    let name = |w: Wrap| match w {
        Wrap::Repeat => "repeat",
        Wrap::Clamp => "clamp",
        Wrap::Mirror => "mirror",
    };
    let wrap = match sampler.wrap_s == sampler.wrap_t {
        true => name(sampler.wrap_s).to_owned(),
        false => format!(
            "{} in u, {} in v",
            name(sampler.wrap_s),
            name(sampler.wrap_t)
        ),
    };
    let filter = match sampler.filter {
        Filter::Bilinear => "bilinear",
        Filter::Nearest => "nearest",
    };
    format!(" ({wrap}, {filter})")
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

#[cfg(test)]
mod tests {
    use super::*;
    use ember::scene::Channel;

    #[test]
    fn a_gltf_material_is_described_with_its_factors_and_gltf_names() {
        let mut m = Material::metallic_roughness("steel", Vec3::new(0.5, 0.5, 0.6), 1.0, 0.5);
        m.diffuse_texture = Some(0);
        m.maps.roughness = Some(1);
        m.maps.roughness_channel = Channel::Green;
        m.maps.metallic = Some(1);
        m.maps.metallic_channel = Channel::Blue;
        assert_eq!(
            describe(&m),
            "glTF metallic-roughness, base colour (0.5,0.5,0.6), metallic 1, roughness 0.5 \
             (alpha 0.25), maps baseColorTexture metallicRoughnessTexture"
        );
    }
}
