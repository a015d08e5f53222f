//! The scene as the wavefront's stages gather it: per-triangle and per-emitter columns,
//! indexed by a lane's primitive or emitter, so that a stage reads one row per lane
//! instead of walking the scalar scene's indirections (triangle → vertices → material).

use glam::Vec3;

use crate::color::luminance;
use crate::sampling::AliasTable;
use crate::scene::{MaterialMaps, Model, Scene};

/// The triangles, materials and emitters of a scene the wavefront engine can render.
#[derive(Clone, Debug)]
pub struct LaneScene {
    /// Each triangle's corners, in winding order.
    pub corners: [Vec<[f32; 3]>; 3],
    /// Each triangle's unit geometric normal (its winding's side).
    pub normal: Vec<[f32; 3]>,
    /// Each triangle's Lambert albedo and emitted radiance (its material's).
    pub albedo: Vec<[f32; 3]>,
    pub emission: Vec<[f32; 3]>,
    /// Each triangle's density of light sampling per unit area (its emitter's choice
    /// probability over its area), 0 for triangles that do not emit.
    pub light_density: Vec<f32>,
    pub emitters: Emitters,
}

/// The emitters, chosen by an alias table in proportion to power, then a uniform
/// point on the chosen triangle: the scalar sampler's `Alias` choice.
#[derive(Clone, Debug)]
pub struct Emitters {
    /// Bin `i`'s coin: keep outcome `i` with probability `keep[i]`, else `alias[i]`.
    pub keep: Vec<f32>,
    pub alias: Vec<u32>,
    /// Each emitter's corners, its unit normal, its density per unit area and its
    /// radiance.
    pub corners: [Vec<[f32; 3]>; 3],
    pub normal: Vec<[f32; 3]>,
    pub density: Vec<f32>,
    pub emission: Vec<[f32; 3]>,
}

impl Emitters {
    pub fn len(&self) -> usize {
        self.keep.len()
    }

    pub fn is_empty(&self) -> bool {
        self.keep.is_empty()
    }
}

impl LaneScene {
    /// The scene laid out for the wavefront, or what it has that the wavefront engine
    /// does not render yet.
    pub fn new(scene: &Scene) -> Result<LaneScene, String> {
        unsupported(scene)?;
        let mesh = &scene.mesh;
        let n = mesh.triangles.len();
        let corners: [Vec<[f32; 3]>; 3] =
            std::array::from_fn(|c| (0..n).map(|t| mesh.vertices(t as u32)[c].into()).collect());
        let normal = (0..n)
            .map(|t| mesh.area_normal(t as u32).normalize_or_zero().into())
            .collect();
        let material = |t: usize| &scene.materials[mesh.material[t] as usize];
        let albedo = (0..n).map(|t| material(t).diffuse.into()).collect();
        let emission = (0..n).map(|t| material(t).emission.into()).collect();
        let emitters = emitters(scene);
        let mut light_density = vec![0.0; n];
        for (&prim, &density) in scene.emitters.iter().zip(&emitters.density) {
            light_density[prim as usize] = density;
        }
        Ok(LaneScene {
            corners,
            normal,
            albedo,
            emission,
            light_density,
            emitters,
        })
    }
}

/// The emitters' alias table (power = area × luminance of `Ke`) and their rows.
fn emitters(scene: &Scene) -> Emitters {
    let mesh = &scene.mesh;
    let ke = |t: u32| scene.materials[mesh.material[t as usize] as usize].emission;
    let weights: Vec<f32> = scene
        .emitters
        .iter()
        .map(|&t| mesh.area(t) * luminance(ke(t)).max(0.0))
        .collect();
    let table = AliasTable::new(&weights).unwrap_or_default();
    let entries: Vec<_> = (0..table.len()).map(|i| table.entry(i)).collect();
    let row = |f: &dyn Fn(u32) -> Vec3| scene.emitters.iter().map(|&t| f(t).into()).collect();
    Emitters {
        keep: entries.iter().map(|e| e.keep).collect(),
        alias: entries.iter().map(|e| e.alias).collect(),
        corners: std::array::from_fn(|c| row(&|t| mesh.vertices(t)[c])),
        normal: row(&|t| mesh.area_normal(t).normalize_or_zero()),
        density: (0..table.len())
            .zip(&scene.emitters)
            .map(|(i, &t)| match mesh.area(t) {
                a if a > 0.0 => table.pmf(i) / a,
                _ => 0.0,
            })
            .collect(),
        emission: row(&|t| ke(t)),
    }
}

fn no_maps(maps: &MaterialMaps) -> bool {
    let MaterialMaps {
        specular,
        shininess,
        emission,
        roughness,
        metallic,
        bump,
        normal,
        ..
    } = maps;
    [
        specular, shininess, emission, roughness, metallic, bump, normal,
    ]
    .iter()
    .all(|m| m.is_none())
}

/// What the wavefront engine does not render yet, as one reason.
fn unsupported(scene: &Scene) -> Result<(), String> {
    let lambert = scene.materials.iter().all(|m| {
        m.model == Model::Lambert
            && m.specular == Vec3::ZERO
            && m.metallic == 0.0
            && m.diffuse_texture.is_none()
            && no_maps(&m.maps)
            && m.opacity >= 1.0
            && m.opacity_map.is_none()
    });
    let reason = if !lambert {
        "materials other than untextured, opaque Lambert"
    } else if scene.materials.iter().any(|m| m.two_sided_emission) {
        "two-sided emitters"
    } else if scene.instancing.is_some() {
        "instances"
    } else if !scene.mesh.normals.is_empty() {
        "shading normals"
    } else if !scene.mesh.colours.is_empty() {
        "vertex colours"
    } else if !scene.lights.is_empty() {
        "lights a scene file places"
    } else if scene.sky.is_some() {
        "a sky or environment map"
    } else if scene.emitters.is_empty() {
        "a scene without emitters"
    } else {
        return Ok(());
    };
    Err(format!("the wavefront engine does not render {reason} yet"))
}
