//! What makes two renders produce the same samples: the settings, the camera, the
//! accelerator, the version of the algorithms, and a fingerprint of the scene's values.
//! Checkpoints and shards carry it; resuming and merging require it to be equal.

use glam::{Vec2, Vec3};
use xxhash_rust::xxh3::Xxh3;

use super::RenderSettings;
use crate::accel::AccelKind;
use crate::film::checkpoint::Identity;
use crate::light::LightSamplerKind;
use crate::scene::{
    CameraSettings, Channel, Light, Material, MaterialMaps, Model, Projection, Sampler, Scene,
    Texels, Wrap,
};

/// The version of what turns a (seed, pixel, sample) into a radiance estimate: the
/// samplers, the integrators, the materials. Bump it whenever a change alters any
/// sample's value, so that old checkpoints and shards are not mixed with new samples.
/// CHANGELOG.md names each version and what it changed.
pub const ALGORITHM_VERSION: u32 = 12;

/// The guide's version, by which CHANGELOG.md names it ("The guide (`sd-tree N`)").
pub const GUIDE_VERSION: &str = "sd-tree 13";

/// The identity's `guiding` entry of [`GUIDE_VERSION`]: kept as version 13 first wrote
/// it, so that guided checkpoints and shards made since resume and merge. The words
/// after the version list what it computes; CHANGELOG.md explains each change. A new
/// version is written as `sd-tree N` alone.
const GUIDE_IDENTITY: &str = "sd-tree 13 (emitters' direct light learnt as far as their light samples are blocked, records times the cosine at their vertex, sky samples following a quadtree of the sky seen directly, adjoint-driven roulette, 16-bit quadrant weights, training samples in the render's own sequences, shares learnt against the guide they will be used with, per region after splitting, regions unguided where guiding does not pay, split by records per square root of pixels, azimuth by polynomial, jitter-filtered in space, box-filtered in direction, folded, learnt selection, guided sky samples with a learnt share, training samples in the image)";

/// The identity's entry of a guided render's training iterations.
pub const GUIDING_ITERATIONS: &str = "guiding-iterations";

/// The settings a checkpoint's identity gives to a `--resume` that leaves them to
/// their defaults, which follow `--spp` (and a resume may raise it): guiding's
/// training iterations and adaptive sampling's `--min-spp`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ResumedDefaults {
    pub guiding_iterations: Option<u32>,
    pub min_spp: Option<u32>,
}

impl ResumedDefaults {
    /// What `identity` (a checkpoint's or shard's) says of them.
    pub fn of(identity: &Identity) -> ResumedDefaults {
        let entry = |key: &str| identity.iter().find(|(k, _)| k == key).map(|(_, v)| v);
        ResumedDefaults {
            guiding_iterations: entry(GUIDING_ITERATIONS).and_then(|v| v.parse().ok()),
            // "threshold 0.05, min-spp 32", as `identity` writes it.
            min_spp: entry("adaptive")
                .and_then(|v| v.split_once(", min-spp "))
                .and_then(|(_, n)| n.parse().ok()),
        }
    }
}

/// The identity of a render, as (name, value) pairs in a fixed order. Floats are written
/// with `{:?}`, which round-trips exactly.
pub fn identity(
    scene: &Scene,
    camera: &CameraSettings,
    settings: &RenderSettings,
    accel: AccelKind,
) -> Identity {
    let v = |v: Vec3| format!("{:?},{:?},{:?}", v.x, v.y, v.z);
    // The sampler the render uses, `auto` resolved by the scene's emitters; only one
    // other than version 10's alias table is named, so that a render with that table
    // (the default with few emitters) has the identity, checkpoints and shards of
    // versions without the choice. The four-wide BVH with plane tests is `bvh4 2`:
    // the binary tree's `bvh` and the plane-less `bvh4` checkpoints are refused.
    let light_sampler = match settings.light_sampler.resolve(scene.light_choices()) {
        LightSamplerKind::Auto => unreachable!("resolved"),
        LightSamplerKind::Alias => None,
        LightSamplerKind::SolidAngle => Some("solid-angle"),
        LightSamplerKind::Bvh => Some("bvh4 2"),
    };
    let mut pairs: Vec<(&str, String)> = vec![
        ("width", settings.width.to_string()),
        ("height", settings.height.to_string()),
        ("max-depth", settings.max_depth.to_string()),
        ("seed", settings.seed.to_string()),
        (
            "integrator",
            format!("{:?}", settings.integrator).to_lowercase(),
        ),
        // Adaptive sampling decides which samples are taken.
        (
            "adaptive",
            settings.adaptive.map_or("none".to_string(), |a| {
                format!("threshold {:?}, min-spp {}", a.threshold, a.min_spp)
            }),
        ),
        // The field of view before the eye: the default eye is derived from it. An
        // orthographic camera names its height there instead.
        match camera.projection {
            Projection::Perspective { vfov_degrees } => ("fov", format!("{vfov_degrees:?}")),
            Projection::Orthographic { height } => ("ortho-height", format!("{height:?}")),
        },
        ("eye", v(camera.eye)),
        ("look-at", v(camera.look_at)),
        ("up", v(camera.up)),
        // The sky's values are part of the scene hash.
        (
            "sky",
            if scene.sky.is_some() { "map" } else { "none" }.to_string(),
        ),
        // The backends may break floating-point ties differently.
        ("accel", format!("{accel:?}").to_lowercase()),
        ("algorithm", ALGORITHM_VERSION.to_string()),
        ("scene", format!("{:016x}", scene_hash(scene))),
    ];
    // Only a lens is named, so that pinhole renders keep their identity.
    if !camera.lens.is_pinhole() {
        let focus = camera
            .lens
            .focus_distance
            .map_or("look-at".into(), |d| format!("{d:?}"));
        pairs.push((
            "lens",
            format!(
                "aperture radius {:?}, focus {focus}",
                camera.lens.aperture_radius
            ),
        ));
    }
    // Only the wavefront is named, so that the scalar loop's renders keep their
    // identity: the engines draw their samples' numbers differently.
    if settings.engine == super::Engine::Wavefront {
        pairs.push(("engine", "wavefront 1".to_owned()));
    }
    if let Some(name) = light_sampler {
        // After the integrator, as where it was first added.
        pairs.insert(5, ("light-sampler", name.to_owned()));
    }
    // Only guided renders name their guide, so that unguided checkpoints and shards
    // made before guiding existed keep their identity; the guide's name changes when
    // what a guided sample computes does (not ALGORITHM_VERSION, which unguided
    // renders share: theirs did not change).
    // The iteration count stands apart, so that `--resume` can take it from a
    // checkpoint (see `GUIDING_ITERATIONS`).
    let guiding = settings.guiding.into_iter().flat_map(|g| {
        [
            ("guiding", GUIDE_IDENTITY.to_owned()),
            (GUIDING_ITERATIONS, g.iterations.to_string()),
        ]
    });
    pairs
        .into_iter()
        .chain(guiding)
        .map(|(k, v)| (k.to_owned(), v))
        .collect()
}

/// Feeds values to the hash with their bit patterns, so that equal scenes hash equally
/// on every platform and Rust version, and any changed value changes the hash.
struct Fingerprint(Xxh3);

impl Fingerprint {
    fn u32s(&mut self, values: impl IntoIterator<Item = u32>) {
        // The same bytes as one update per value (so the same hash), in blocks: a
        // multi-million-triangle mesh hashes in milliseconds instead of a tenth of a second.
        let mut block = [0u8; 4096];
        let mut filled = 0;
        for v in values {
            block[filled..filled + 4].copy_from_slice(&v.to_le_bytes());
            filled += 4;
            if filled == block.len() {
                self.0.update(&block);
                filled = 0;
            }
        }
        self.0.update(&block[..filled]);
    }

    fn f32s(&mut self, values: impl IntoIterator<Item = f32>) {
        self.u32s(values.into_iter().map(f32::to_bits));
    }

    fn vec3s<'a>(&mut self, values: impl IntoIterator<Item = &'a Vec3>) {
        self.f32s(values.into_iter().flat_map(|v| v.to_array()));
    }

    fn texels(&mut self, texels: &Texels) {
        match texels {
            Texels::Srgb8(t) => {
                self.u32s([0]);
                self.0.update(t);
            }
            Texels::Rgb8(t) => {
                self.u32s([1]);
                self.0.update(t);
            }
            Texels::Gray8(t) => {
                self.u32s([2]);
                self.0.update(t);
            }
            Texels::RgbF32(t) => {
                self.u32s([3]);
                self.vec3s(t);
            }
            Texels::GrayF32(t) => {
                self.u32s([4]);
                self.f32s(t.iter().copied());
            }
        }
    }

    /// A texture's sampler, only when it is not the default (repeat, bilinear), so that
    /// the fingerprints of scenes made before samplers existed stay as they were.
    fn sampler(&mut self, sampler: Sampler) {
        if sampler != Sampler::default() {
            let code = |w: Wrap| w as u32;
            let filter = sampler.filter as u32;
            self.u32s([u32::MAX, code(sampler.wrap_s), code(sampler.wrap_t), filter]);
        }
    }

    /// A list's length first, so that `[a, b] + [c]` and `[a] + [b, c]` differ.
    fn len(&mut self, n: usize) {
        self.0.update(&(n as u64).to_le_bytes());
    }

    fn light(&mut self, light: &Light) {
        match light {
            Light::Point(point) => {
                self.u32s([if point.spot.is_some() { 2 } else { 0 }]);
                self.vec3s([&point.position, &point.intensity]);
                if let Some(cone) = &point.spot {
                    self.vec3s([&cone.axis]);
                    self.f32s([cone.cos_inner, cone.cos_outer]);
                }
            }
            Light::Directional(sun) => {
                self.u32s([1]);
                self.vec3s([&sun.direction, &sun.irradiance]);
                self.f32s([sun.half_angle]);
            }
        }
    }

    fn material(&mut self, m: &Material) {
        // Destructured whole: a new field fails to compile here until it is hashed.
        let Material {
            name: _, // names do not shape the image
            diffuse,
            diffuse_texture,
            specular,
            emission,
            model,
            roughness,
            shininess,
            metallic,
            maps,
            opacity,
            opacity_map,
            two_sided_emission,
        } = m;
        let id = |t: Option<u32>| t.map_or(u32::MAX, |t| t);
        let MaterialMaps {
            specular: specular_map,
            shininess: shininess_map,
            emission: emission_map,
            roughness: roughness_map,
            roughness_channel,
            metallic: metallic_map,
            metallic_channel,
            transmission: transmission_map,
            bump,
            bump_scale,
            normal,
        } = *maps;
        self.u32s(
            [
                specular_map,
                shininess_map,
                emission_map,
                roughness_map,
                metallic_map,
                bump,
                normal,
            ]
            .map(id),
        );
        self.f32s([
            roughness.unwrap_or(-1.0),
            shininess.unwrap_or(-1.0),
            *metallic,
            bump_scale,
        ]);
        // Only channels other than the default are hashed, like cut-outs below.
        if (roughness_channel, metallic_channel) != (Channel::Red, Channel::Red) {
            self.u32s([roughness_channel as u32, metallic_channel as u32]);
        }
        // Likewise the transmission map, which glTF's transmission alone has.
        if let Some(map) = transmission_map {
            self.u32s([map]);
        }
        // Only cut-outs are hashed, so that opaque scenes keep the fingerprint they had
        // before opacity existed (and their checkpoints stay resumable).
        if !m.is_opaque() {
            self.f32s([*opacity]);
            self.u32s([opacity_map.map_or(u32::MAX, |t| t)]);
        }
        // Only two-sided emission is hashed, so that one-sided scenes keep theirs.
        if *two_sided_emission {
            self.u32s([u32::from(*two_sided_emission)]);
        }
        self.vec3s([diffuse, specular, emission]);
        self.u32s([diffuse_texture.map_or(u32::MAX, |t| t)]);
        match *model {
            Model::Lambert => self.u32s([0]),
            Model::Conductor { alpha } => {
                self.u32s([1]);
                self.f32s([alpha]);
            }
            Model::Coated { alpha } => {
                self.u32s([2]);
                self.f32s([alpha]);
            }
            Model::Glass { ior } => {
                self.u32s([3]);
                self.f32s([ior]);
            }
            Model::MetallicRoughness {
                alpha,
                ior,
                specular,
                transmission,
            } => {
                self.u32s([4]);
                self.f32s([alpha, ior, specular]);
                // Hashed only where there is some, as cut-outs are.
                if transmission > 0.0 {
                    self.f32s([transmission]);
                }
            }
        }
    }
}

/// A fingerprint (XXH3, 64 bits) of every value in the scene that shapes the image:
/// vertices, normals, texture coordinates, triangles and their materials, the
/// materials' numbers, the textures' texels, and the placed lights.
pub fn scene_hash(scene: &Scene) -> u64 {
    let mut h = Fingerprint(Xxh3::new());
    let m = &scene.mesh;
    h.len(m.positions.len());
    h.vec3s(&m.positions);
    h.len(m.normals.len());
    h.vec3s(&m.normals);
    h.len(m.uvs.len());
    h.f32s(m.uvs.iter().flat_map(Vec2::to_array));
    // Only where there are any, so that the fingerprints of scenes without vertex
    // colours (and their checkpoints) stay as they were.
    if !m.colours.is_empty() {
        h.len(m.colours.len());
        h.vec3s(&m.colours);
    }
    h.len(m.triangles.len());
    h.u32s(m.triangles.iter().flatten().copied());
    h.u32s(m.material.iter().copied());
    h.len(scene.materials.len());
    for material in &scene.materials {
        h.material(material);
    }
    h.len(scene.textures.len());
    for t in &scene.textures {
        h.u32s([t.width, t.height]);
        h.texels(&t.texels);
        h.sampler(t.sampler);
    }
    if !scene.alpha_maps.is_empty() {
        h.len(scene.alpha_maps.len());
        for a in &scene.alpha_maps {
            h.u32s([a.width, a.height]);
            h.0.update(&a.texels);
            h.sampler(a.sampler);
        }
    }
    if let Some(sky) = &scene.sky {
        h.u32s(sky.identity_words());
    }
    // Only scenes with lights that are not geometry hash them, so that the others keep
    // their fingerprint (area lights are triangles, hashed with the mesh).
    if !scene.lights.is_empty() {
        h.len(scene.lights.len());
        for light in &scene.lights {
            h.light(light);
        }
    }
    // Only instanced scenes hash their placements, so that plain scenes keep the
    // fingerprint they had before instancing existed.
    if let Some(instancing) = &scene.instancing {
        h.len(instancing.parts.len());
        for part in &instancing.parts {
            h.u32s([part.triangles.start, part.triangles.end]);
        }
        h.len(instancing.instances.len());
        for instance in &instancing.instances {
            h.u32s([instance.mesh]);
            h.f32s(instance.transform.to_cols_array());
        }
    }
    h.0.digest()
}

#[cfg(test)]
mod guide_identity_tests {
    use super::*;

    #[test]
    fn the_guide_identity_is_its_version_and_keeps_version_13s_text() {
        assert!(GUIDE_IDENTITY.starts_with(&format!("{GUIDE_VERSION} (")));
        // Guided checkpoints made by version 13 carry this text; changing it would make
        // them unresumable without a rule to accept the old text.
        assert_eq!(GUIDE_IDENTITY.len(), 629);
        assert!(GUIDE_IDENTITY.ends_with(", training samples in the image)"));
    }
}
