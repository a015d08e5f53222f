//! glTF materials as ember's: the metallic-roughness parameters, their textures, the
//! emission, the normal map, alpha and the texture coordinates each material reads.
//!
//! [`metallic_roughness`] makes each an ember [`Model::MetallicRoughness`] material
//! (the specification's BRDF): factors multiply their textures, and the one
//! metallic-roughness texture feeds roughness (green) and metallic (blue).
//! `KHR_materials_ior`, `KHR_materials_specular` and `KHR_materials_transmission` set
//! the dielectric (see [`Dielectric`]); the specular texture, a map of
//! `specularFactor` in an alpha channel, is not read (one warning).
//!
//! Occlusion textures are ignored (a path tracer computes occlusion). `doubleSided`
//! makes an emissive material emit from both faces, as the specification's
//! double-sided lighting (the back face lit with its normal reversed) and Cycles do;
//! without it only the counter-clockwise face emits. Reflection needs no flag: ember
//! shades both sides of every surface.
//! One set of texture coordinates and one `KHR_texture_transform` serve all of a
//! material's textures: its base colour texture's (else its first texture's), baked into
//! the texture coordinates of the primitives that use it.

use std::collections::BTreeMap;

use glam::{Mat3, Vec2, Vec3};
use gltf::material::AlphaMode;

use super::images::{make_textures, Made, Purpose};
use super::source::Source;
use crate::scene::warnings::Warnings;
use crate::scene::{Channel, Material, MaterialMaps, Model, SceneError};

/// Which texture coordinates a material's primitives read, and how they are moved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvChoice {
    /// The `TEXCOORD_n` set.
    pub set: u32,
    /// `KHR_texture_transform` as a 2D affine matrix, in glTF's texture space.
    pub transform: Option<Mat3>,
}

impl UvChoice {
    /// glTF texture coordinates as ember reads them: moved by the transform, then with
    /// `v` flipped (glTF's origin is the image's top left, ember's its bottom left).
    pub fn apply(&self, uv: Vec2) -> Vec2 {
        let uv = match &self.transform {
            Some(m) => m.transform_point2(uv),
            None => uv,
        };
        Vec2::new(uv.x, 1.0 - uv.y)
    }
}

/// What `KHR_materials_ior`, `KHR_materials_specular` and `KHR_materials_transmission`
/// say of a material's dielectric; the defaults are the core specification's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dielectric {
    /// The index of refraction: 1.5, or at least 1; infinite for the extension's 0.
    pub ior: f32,
    /// `specularFactor`, in [0, 1].
    pub specular: f32,
    /// `specularColorFactor` (≥ 0), which scales `F0`.
    pub specular_colour: Vec3,
    /// `transmissionFactor`, in [0, 1].
    pub transmission: f32,
}

impl Default for Dielectric {
    fn default() -> Self {
        Dielectric {
            ior: 1.5,
            specular: 1.0,
            specular_colour: Vec3::ONE,
            transmission: 0.0,
        }
    }
}

impl Dielectric {
    /// The extensions' values of `material`, or why one of them cannot be used.
    fn of(material: &gltf::Material<'_>) -> Result<Dielectric, String> {
        let mut d = Dielectric::default();
        if let Some(ior) = material.ior() {
            d.ior = match ior {
                0.0 => f32::INFINITY,
                ior if ior >= 1.0 && ior.is_finite() => ior,
                ior => {
                    return Err(format!(
                        "its KHR_materials_ior ior {ior} is out of range: it is at least 1, \
                         or 0 for an infinite index"
                    ))
                }
            };
        }
        if let Some(specular) = material.specular() {
            d.specular = specular.specular_factor();
            d.specular_colour = Vec3::from(specular.specular_color_factor());
        }
        if let Some(transmission) = material.transmission() {
            d.transmission = transmission.transmission_factor();
        }
        let unit = |x: f32| (0.0..=1.0).contains(&x);
        let bad = |key: &str, value: String, range: &str| {
            Err(format!("its {key} {value} is out of range: it is {range}"))
        };
        if !unit(d.specular) {
            return bad("specularFactor", d.specular.to_string(), "in [0, 1]");
        }
        let colour = d.specular_colour;
        if !(colour.is_finite() && colour.min_element() >= 0.0) {
            let rgb = format!("[{}, {}, {}]", colour.x, colour.y, colour.z);
            return bad("specularColorFactor", rgb, "finite and not negative");
        }
        if !unit(d.transmission) {
            return bad(
                "transmissionFactor",
                d.transmission.to_string(),
                "in [0, 1]",
            );
        }
        Ok(d)
    }
}

/// A glTF material's parameters with its textures' indices in the scene.
#[derive(Clone, Debug, Default)]
pub struct GltfValues {
    pub name: String,
    pub base_colour: Vec3,
    pub base_texture: Option<u32>,
    pub metallic: f32,
    pub roughness: f32,
    /// Roughness in its green channel, metallic in its blue.
    pub metallic_roughness_texture: Option<u32>,
    pub emission: Vec3,
    pub emission_texture: Option<u32>,
    pub normal_texture: Option<u32>,
    pub opacity: f32,
    pub opacity_map: Option<u32>,
    pub dielectric: Dielectric,
    /// `specularColorTexture` (sRGB).
    pub specular_colour_texture: Option<u32>,
    /// `transmissionTexture`, read through its red channel.
    pub transmission_texture: Option<u32>,
    /// `doubleSided`.
    pub double_sided: bool,
}

/// The one mapping from glTF's metallic-roughness parameters to an ember material.
pub fn metallic_roughness(v: &GltfValues) -> Material {
    let mut material =
        Material::metallic_roughness(&v.name, v.base_colour, v.metallic, v.roughness);
    let d = v.dielectric;
    if let Model::MetallicRoughness {
        ior,
        specular,
        transmission,
        ..
    } = &mut material.model
    {
        (*ior, *specular, *transmission) = (d.ior, d.specular, d.transmission);
    }
    material.specular = d.specular_colour;
    material.diffuse_texture = v.base_texture;
    material.emission = v.emission.max(Vec3::ZERO);
    material.maps = MaterialMaps {
        specular: v.specular_colour_texture,
        emission: v.emission_texture,
        roughness: v.metallic_roughness_texture,
        roughness_channel: Channel::Green,
        metallic: v.metallic_roughness_texture,
        metallic_channel: Channel::Blue,
        transmission: v.transmission_texture,
        normal: v.normal_texture,
        bump_scale: 1.0,
        ..MaterialMaps::default()
    };
    material.opacity = v.opacity;
    material.opacity_map = v.opacity_map;
    material.two_sided_emission = v.double_sided && material.is_emissive();
    material
}

/// The materials of a glTF, with the default material last, their textures, and the
/// texture coordinates each reads.
pub struct Materials {
    pub materials: Vec<Material>,
    pub uv: Vec<UvChoice>,
    pub made: Made,
}

/// A texture slot of a material: its glTF texture (image and sampler), the texture
/// coordinates it names and its transform.
struct Slot {
    texture: usize,
    uv: UvChoice,
    /// The glTF name of the slot, for messages.
    name: &'static str,
}

fn slot(info: &gltf::texture::Info<'_>, name: &'static str) -> Result<Slot, String> {
    let transform = info.texture_transform();
    let set = transform
        .as_ref()
        .and_then(|t| t.tex_coord())
        .unwrap_or(info.tex_coord());
    let matrix = match transform {
        None => None,
        Some(t) => Some(texture_transform(t.offset(), t.rotation(), t.scale())?),
    };
    Ok(Slot {
        texture: info.texture().index(),
        uv: UvChoice {
            set,
            transform: matrix,
        },
        name,
    })
}

/// `KHR_texture_transform`'s matrix, translation · rotation · scale, acting on glTF's
/// texture coordinates (before ember flips `v`).
pub fn texture_transform(offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> Result<Mat3, String> {
    let numbers = [offset[0], offset[1], rotation, scale[0], scale[1]];
    if !numbers.iter().all(|x| x.is_finite()) {
        return Err("a KHR_texture_transform with a number that is not finite".into());
    }
    let (s, c) = rotation.sin_cos();
    let translation = Mat3::from_cols(Vec3::X, Vec3::Y, Vec3::new(offset[0], offset[1], 1.0));
    // The extension's GLSL `mat3(cos, sin, 0, -sin, cos, 0, 0, 0, 1)`, column by column.
    let rotation = Mat3::from_cols(Vec3::new(c, s, 0.0), Vec3::new(-s, c, 0.0), Vec3::Z);
    let scale = Mat3::from_diagonal(Vec3::new(scale[0], scale[1], 1.0));
    Ok(translation * rotation * scale)
}

/// Reads every material of the document, decodes the textures they use, and maps
/// each with [`metallic_roughness`].
pub fn read_materials(source: &Source, warnings: &mut Warnings) -> Result<Materials, SceneError> {
    let document = &source.document;
    let bad = |name: &str, reason: String| SceneError::Gltf {
        path: source.path.clone(),
        reason: format!("material {name:?}: {reason}"),
    };
    // First what each material asks of which image, so each image is decoded once.
    let mut requests: BTreeMap<(usize, Purpose), (String, String)> = BTreeMap::new();
    let mut plans = Vec::new();
    for material in document.materials() {
        let name = material_name(&material);
        let plan = plan(&material, &name).map_err(|reason| bad(&name, reason))?;
        for (key, instead) in &plan.requests {
            requests
                .entry(*key)
                .or_insert_with(|| (name.clone(), instead.clone()));
        }
        if plan.specular_map_ignored {
            warnings.push(format!(
                "material {name:?}: its KHR_materials_specular specularTexture (a map of \
                 specularFactor in its alpha channel) is not read; ember uses the \
                 specularFactor {} everywhere",
                plan.values.dielectric.specular
            ));
        }
        if plan.mixed_uvs {
            warnings.push(format!(
                "material {name:?}: its textures read different texture coordinates or \
                 transforms; ember uses its {}'s for all of them",
                plan.uv_from
            ));
        }
        plans.push((name, plan));
    }
    let made = make_textures(source, &requests, warnings)?;
    let id = |key: Option<(usize, Purpose)>| key.and_then(|k| made.ids.get(&k).copied().flatten());
    let mut materials = Vec::with_capacity(plans.len() + 1);
    let mut uv = Vec::with_capacity(plans.len());
    for (name, plan) in plans {
        let opacity_map = id(plan.alpha);
        let values = GltfValues {
            name,
            // An alpha map holds the factor (and the cut) itself.
            opacity: match opacity_map {
                Some(_) => 1.0,
                None => plan.values.opacity,
            },
            base_texture: id(plan.base),
            metallic_roughness_texture: id(plan.metallic_roughness),
            emission_texture: id(plan.emission),
            normal_texture: id(plan.normal),
            specular_colour_texture: id(plan.specular_colour),
            transmission_texture: id(plan.transmission),
            opacity_map,
            ..plan.values
        };
        materials.push(metallic_roughness(&values));
        uv.push(plan.uv);
    }
    Ok(Materials {
        materials,
        uv,
        made,
    })
}

/// A material's name, or `material N` for one without.
fn material_name(material: &gltf::Material<'_>) -> String {
    match (material.name(), material.index()) {
        (Some(name), _) => name.to_owned(),
        (None, Some(i)) => format!("material {i}"),
        (None, None) => "default".to_owned(),
    }
}

/// What one material asks for: its constants, and for each map the (glTF texture,
/// purpose) it is made from.
struct Plan {
    values: GltfValues,
    base: Option<(usize, Purpose)>,
    metallic_roughness: Option<(usize, Purpose)>,
    emission: Option<(usize, Purpose)>,
    normal: Option<(usize, Purpose)>,
    alpha: Option<(usize, Purpose)>,
    specular_colour: Option<(usize, Purpose)>,
    transmission: Option<(usize, Purpose)>,
    /// Whether the material has a specular texture, which ember does not read.
    specular_map_ignored: bool,
    /// Every request with what the material uses where its image is absent.
    requests: Vec<((usize, Purpose), String)>,
    uv: UvChoice,
    uv_from: &'static str,
    mixed_uvs: bool,
}

/// A material's plan, or why a number of it cannot be used.
fn plan(material: &gltf::Material<'_>, name: &str) -> Result<Plan, String> {
    let pbr = material.pbr_metallic_roughness();
    let base = pbr.base_color_factor();
    let strength = material.emissive_strength().unwrap_or(1.0);
    let numbers = [
        ("baseColorFactor", &base[..]),
        ("metallicFactor", &[pbr.metallic_factor()][..]),
        ("roughnessFactor", &[pbr.roughness_factor()][..]),
        ("emissiveFactor", &material.emissive_factor()[..]),
        ("emissiveStrength", &[strength][..]),
        ("alphaCutoff", &[material.alpha_cutoff().unwrap_or(0.5)][..]),
    ];
    for (key, values) in numbers {
        if !values.iter().all(|x| x.is_finite()) {
            return Err(format!("its {key} is not finite"));
        }
    }
    if material
        .normal_texture()
        .is_some_and(|n| !n.scale().is_finite())
    {
        return Err("its normalTexture's scale is not finite".into());
    }
    let colour = Vec3::new(base[0], base[1], base[2]);
    let mut values = GltfValues {
        name: name.to_owned(),
        base_colour: colour,
        metallic: pbr.metallic_factor(),
        roughness: pbr.roughness_factor(),
        emission: Vec3::from(material.emissive_factor()) * strength.max(0.0),
        opacity: 1.0,
        dielectric: Dielectric::of(material)?,
        double_sided: material.double_sided(),
        ..GltfValues::default()
    };
    let mut slots = Vec::new();
    let mut requests = Vec::new();
    let mut ask = |texture: usize, purpose: Purpose, instead: String| {
        let key = (texture, purpose);
        requests.push((key, instead));
        Some(key)
    };
    let rgb = |v: Vec3| format!("{} {} {}", v.x, v.y, v.z);
    let (mut base_key, mut metallic_roughness, mut emission, mut normal, mut alpha) =
        (None, None, None, None, None);
    if let Some(info) = pbr.base_color_texture() {
        let s = slot(&info, "baseColorTexture")?;
        let instead = format!(
            "the material uses its baseColorFactor {} instead",
            rgb(colour)
        );
        base_key = ask(s.texture, Purpose::BaseColour, instead);
        slots.push(s);
    }
    if let Some(info) = pbr.metallic_roughness_texture() {
        let s = slot(&info, "metallicRoughnessTexture")?;
        let instead = format!(
            "the material uses its metallicFactor {} and roughnessFactor {} instead",
            values.metallic, values.roughness
        );
        metallic_roughness = ask(s.texture, Purpose::MetallicRoughness, instead);
        slots.push(s);
    }
    if let Some(info) = material.emissive_texture() {
        let s = slot(&info, "emissiveTexture")?;
        let instead = format!(
            "the material uses its emissiveFactor {} instead",
            rgb(values.emission)
        );
        emission = ask(s.texture, Purpose::Emission, instead);
        slots.push(s);
    }
    // The specular colour is an sRGB colour as the base colour is, the transmission
    // linear data as the metallic-roughness texture is: the same decodings.
    let (mut specular_colour, mut transmission) = (None, None);
    let specular = material.specular();
    if let Some(info) = specular.as_ref().and_then(|s| s.specular_color_texture()) {
        let s = slot(&info, "specularColorTexture")?;
        let instead = format!(
            "the material uses its specularColorFactor {} instead",
            rgb(values.dielectric.specular_colour)
        );
        specular_colour = ask(s.texture, Purpose::BaseColour, instead);
        slots.push(s);
    }
    if let Some(info) = material
        .transmission()
        .and_then(|t| t.transmission_texture())
    {
        let s = slot(&info, "transmissionTexture")?;
        let instead = format!(
            "the material uses its transmissionFactor {} instead",
            values.dielectric.transmission
        );
        transmission = ask(s.texture, Purpose::MetallicRoughness, instead);
        slots.push(s);
    }
    let specular_map_ignored = specular.is_some_and(|s| s.specular_texture().is_some());
    if let Some(n) = material.normal_texture() {
        let s = Slot {
            texture: n.texture().index(),
            uv: UvChoice {
                set: n.tex_coord(),
                transform: None,
            },
            name: "normalTexture",
        };
        let instead = "the surface is shaded with its own normals".to_owned();
        normal = ask(s.texture, Purpose::Normal(n.scale().to_bits()), instead);
        slots.push(s);
    }
    let alpha_factor = base[3].clamp(0.0, 1.0);
    let cutoff = material.alpha_cutoff().unwrap_or(0.5);
    let cut = match material.alpha_mode() {
        AlphaMode::Opaque => None,
        AlphaMode::Mask => Some(Some(cutoff)),
        AlphaMode::Blend => Some(None),
    };
    if let Some(cutoff) = cut {
        values.opacity = match cutoff {
            Some(c) if alpha_factor >= c => 1.0,
            Some(_) => 0.0,
            None => alpha_factor,
        };
        if let Some((texture, _)) = base_key {
            let purpose = Purpose::Alpha {
                factor: alpha_factor.to_bits(),
                cutoff: cutoff.map(f32::to_bits),
            };
            let instead = format!("the material's opacity is {}", values.opacity);
            alpha = ask(texture, purpose, instead);
        }
    }
    let first = slots.first();
    let uv = first.map_or(
        UvChoice {
            set: 0,
            transform: None,
        },
        |s| s.uv,
    );
    // A normal map without a transform of its own follows the others' transform.
    let mixed_uvs = slots
        .iter()
        .any(|s| s.uv.set != uv.set || (s.name != "normalTexture" && s.uv != uv));
    Ok(Plan {
        values,
        base: base_key,
        metallic_roughness,
        emission,
        normal,
        alpha,
        specular_colour,
        transmission,
        specular_map_ignored,
        requests,
        uv,
        uv_from: first.map_or("base colour texture", |s| s.name),
        mixed_uvs,
    })
}
