//! A renderable scene: one triangle mesh, its materials and textures, the list of
//! emissive triangles, and the lights that are not geometry. Immutable once built.

mod area_lights;
mod asset_paths;
mod camera;
mod compose;
mod cutout;
mod environment;
mod file;
mod formats;
mod gltf;
mod instances;
mod light_table;
mod lights;
mod material;
mod mesh;
mod mtl;
mod normal_maps;
mod obj;
mod obj_parallel;
mod obj_text;
mod opacity_map;
mod ply;
mod tangents;
mod texture_files;
mod texture_image;
mod texture_sampler;
mod warnings;

pub use self::gltf::{load_gltf, FileCamera};
pub use area_lights::{
    area_light_scene, AreaEmission, AreaLight, AreaShape, DISK_SEGMENTS, SPHERE_SUBDIVISIONS,
};
pub use camera::{Camera, CameraFrame, CameraSettings, Lens, Projection};
pub use compose::{compose, mirrors, Placement};
pub use cutout::{coin, Opacity, PartOpacity};
pub use environment::{Environment, SkySample};
pub use file::{
    parse_memory_bytes, placement_memory_bytes, ObjFile, Placed, SceneFile, SceneFileError,
    Setting, MEMORY_PER_PLACEMENT,
};
pub use formats::{load_model, LoadedModel, ModelFormat, MODEL_FORMATS};
pub use instances::{instanced, place, Instancing, MeshPart};
pub use light_table::{PlacedLight, SceneLight};
pub use lights::{
    intensity_from_candela, intensity_from_power, irradiance_from_lux, DirectionalLight, Light,
    PointLight, SpotCone, LUMENS_PER_WATT, MAX_SPOT_ANGLE,
};
pub use material::{
    alpha_from_ns, alpha_from_pr, Channel, Material, MaterialMaps, Model, MtlValues, SurfaceParams,
};
pub use mesh::{triangle_bounds, SurfacePoint, TriangleMesh};
pub use normal_maps::{bump, keep_reflection_above, normal_map, uv_derivatives};
pub use obj::{
    check_counts, load_obj, load_obj_from_str, load_obj_with, LoadReport, VertexColours,
    MAX_TRIANGLES, MEMORY_PER_MATERIAL, MEMORY_PER_MTL_BYTE, MEMORY_PER_OBJ_BYTE,
};
#[doc(hidden)]
pub use obj_parallel::check_against_tobj;
pub use opacity_map::AlphaMap;
pub use ply::{load_ply, load_ply_with, MEMORY_PER_PLY_TRIANGLE, MEMORY_PER_PLY_VERTEX};
pub use tangents::mikktspace_tangents;
pub use texture_image::{Texels, Texture, TextureKind};
pub use texture_sampler::{Filter, Sampler, Wrap};
pub use warnings::LoadOptions;

use glam::{Vec2, Vec3, Vec4};
use std::path::PathBuf;
use std::sync::Arc;

use crate::bsdf::Bsdf;
use crate::geometry::Hit;

/// Why a scene could not be loaded. Each message is one line that names the file.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error(transparent)]
    Read(#[from] crate::io::ReadError),
    #[error("{path} is not a valid OBJ file: {reason}")]
    Obj { path: PathBuf, reason: String },
    #[error("PLY file {path}: {reason}")]
    Ply { path: PathBuf, reason: String },
    #[error("{path}: ember reads {MODEL_FORMATS} models, not {what}")]
    Format { path: PathBuf, what: String },
    #[error("material library {path} (named by mtllib in {obj}): {reason}")]
    Mtl {
        path: PathBuf,
        obj: PathBuf,
        reason: String,
    },
    #[error("{path}:{line}: {reason} (in the material library named by mtllib in {obj})")]
    MtlSyntax {
        path: PathBuf,
        line: usize,
        obj: PathBuf,
        reason: String,
    },
    #[error("{path}:{line}: usemtl {name:?} names a material no material library defines")]
    UndefinedMaterial {
        path: PathBuf,
        line: usize,
        name: String,
    },
    #[error("texture {path} ({slot} of material {material:?}): {reason}")]
    Texture {
        path: PathBuf,
        /// The MTL statement that names it (`map_Kd`, `map_d`).
        slot: &'static str,
        material: String,
        reason: String,
    },
    #[error("material {material:?}: {reason}")]
    Material { material: String, reason: String },
    #[error("{path}: {what} {index} is not finite ({value})")]
    NonFinite {
        path: PathBuf,
        what: &'static str,
        index: usize,
        value: String,
    },
    #[error("{path} has no triangles to render{detail}")]
    Empty { path: PathBuf, detail: String },
    #[error("{path}: {what}")]
    TooLarge { path: PathBuf, what: String },
    #[error("{path}: {reason}")]
    Gltf { path: PathBuf, reason: String },
    #[error("environment map {path}: {reason}")]
    Environment { path: PathBuf, reason: String },
}

/// Everything the integrator reads.
#[derive(Clone, Debug)]
pub struct Scene {
    pub mesh: TriangleMesh,
    pub materials: Vec<Material>,
    pub textures: Vec<Arc<Texture>>,
    /// Per-vertex MikkTSpace tangents (xyz, bitangent sign in w) when some material
    /// has a normal map; empty otherwise.
    pub tangents: Vec<Vec4>,
    /// Opacity maps of the materials' cut-outs (`Material::opacity_map`), shared with
    /// the accelerator's [`Opacity`] filter.
    pub alpha_maps: Vec<Arc<AlphaMap>>,
    /// Indices of the triangles whose material emits: of `mesh`, or of the instanced
    /// emitters' world-space mesh ([`Instancing::lights`]) in an instanced scene.
    pub emitters: Vec<u32>,
    /// Radiance arriving where rays leave the scene: an environment map or a uniform
    /// sky; none (black) by default.
    pub sky: Option<Arc<Environment>>,
    /// Where the distinct meshes of `mesh` stand, when they are placed by instances
    /// rather than baked into world space (see [`place`]); `None` for a plain scene.
    pub instancing: Option<Arc<Instancing>>,
    /// Lights that are not geometry (points, spots, directions), which only light
    /// samples reach; area lights are emissive triangles of `mesh` instead.
    pub lights: Vec<Light>,
}

impl Scene {
    /// Assembles a scene, finds its emitters and, when a material has a normal map,
    /// the tangents of that material's triangles.
    pub fn new(mesh: TriangleMesh, materials: Vec<Material>, textures: Vec<Arc<Texture>>) -> Self {
        let emitters = (0..mesh.triangles.len() as u32)
            .filter(|&t| materials[mesh.material[t as usize] as usize].is_emissive())
            .collect();
        let normal_mapped: Vec<u32> = (0..mesh.triangles.len() as u32)
            .filter(|&t| {
                let m = &materials[mesh.material[t as usize] as usize];
                m.maps.normal.is_some()
            })
            .collect();
        let tangents = mikktspace_tangents(&mesh, &normal_mapped);
        Scene {
            mesh,
            materials,
            textures,
            tangents,
            alpha_maps: Vec::new(),
            emitters,
            sky: None,
            instancing: None,
            lights: Vec::new(),
        }
    }

    /// How many lights the light sampler chooses among by its table or tree: the
    /// emissive triangles and the point and spot lights (suns are chosen with the sky).
    pub fn light_choices(&self) -> usize {
        let points = self.lights.iter().filter(|l| matches!(l, Light::Point(_)));
        self.emitters.len() + points.count()
    }

    pub fn material(&self, surface: &SurfacePoint) -> &Material {
        &self.materials[surface.material as usize]
    }

    fn texture(&self, id: u32) -> &Texture {
        &self.textures[id as usize]
    }

    /// The surface at a hit, with its shading normal perturbed by the material's bump
    /// or normal map; in world space, when the hit is on an instance.
    #[inline]
    pub fn surface(&self, hit: &Hit) -> SurfacePoint {
        match &self.instancing {
            None => self.object_surface(hit),
            Some(instancing) => self.instance_surface(instancing, hit),
        }
    }

    /// The surface at a hit on an instance, in the world. A bump or normal map is
    /// applied in object space, where its tangents are, and the normal it gives is
    /// taken to the world by the normal matrix.
    fn instance_surface(&self, instancing: &Instancing, hit: &Hit) -> SurfacePoint {
        let mesh_hit = instancing.mesh_hit(hit);
        let mut surface = instancing.world_surface(&self.mesh, &mesh_hit);
        let maps = &self.material(&surface).maps;
        if maps.perturbs_normal() && !self.mesh.uvs.is_empty() {
            let object = self.object_surface(&mesh_hit);
            let n = instancing.normal_to_world(object.ns, hit.instance);
            surface.ns = if n.dot(surface.ng) < 0.0 {
                (n - 1.001 * n.dot(surface.ng) * surface.ng).normalize_or(surface.ns)
            } else {
                n.normalize_or(surface.ns)
            };
        }
        surface
    }

    /// The mesh the light sampler chooses emitters from: the scene's, or the
    /// world-space emitters of an instanced scene.
    pub fn light_mesh(&self) -> &TriangleMesh {
        match &self.instancing {
            None => &self.mesh,
            Some(instancing) => &instancing.lights,
        }
    }

    /// The hit as the light sampler knows it: the same hit, or in an instanced scene
    /// with `prim` the index of its emitter in [`Scene::light_mesh`] (`u32::MAX` on a
    /// triangle that does not emit).
    #[inline]
    pub fn light_hit(&self, hit: Hit) -> Hit {
        match &self.instancing {
            None => hit,
            Some(instancing) => Hit {
                prim: instancing.light_id(&hit),
                ..hit
            },
        }
    }

    /// The surface at a hit on the scene's mesh, in the mesh's own space.
    #[inline]
    fn object_surface(&self, hit: &Hit) -> SurfacePoint {
        let mut surface = self.mesh.surface(hit);
        let maps = &self.material(&surface).maps;
        if maps.perturbs_normal() && !self.mesh.uvs.is_empty() {
            surface.ns = self.perturbed_normal(hit, &surface);
        }
        surface
    }

    /// The shading normal a bump map (or else a normal map) gives at a hit.
    fn perturbed_normal(&self, hit: &Hit, surface: &SurfacePoint) -> Vec3 {
        let maps = &self.material(surface).maps;
        let corners = self.mesh.triangles[hit.prim as usize].map(|i| i as usize);
        if let Some(id) = maps.bump {
            let p = corners.map(|i| self.mesh.positions[i]);
            return match uv_derivatives(p, self.mesh.corner_uvs(hit.prim)) {
                Some((dpdu, dpdv)) => bump(
                    surface.ns,
                    dpdu,
                    dpdv,
                    self.texture(id),
                    maps.bump_scale,
                    surface.uv,
                ),
                None => surface.ns,
            };
        }
        match (maps.normal, self.tangents.is_empty()) {
            (Some(id), false) => {
                let [a, b, c] = corners.map(|i| self.tangents[i]);
                let tangent = (1.0 - hit.u - hit.v) * a + hit.u * b + hit.v * c;
                let n = normal_map(surface.ns, tangent, self.texture(id), surface.uv);
                // Keep it on the geometric side; the BSDF bends it further if needed.
                if n.dot(surface.ng) < 0.0 {
                    (n - 1.001 * n.dot(surface.ng) * surface.ng).normalize_or(surface.ns)
                } else {
                    n
                }
            }
            _ => surface.ns,
        }
    }

    /// The diffuse reflectance at a surface point (texture lookup where there is one),
    /// clamped to [0, 1] like `Kd`, times the vertex colour.
    pub fn albedo(&self, surface: &SurfacePoint) -> Vec3 {
        let material = self.material(surface);
        self.colour(
            material,
            material.diffuse_texture,
            material.diffuse,
            surface.uv,
        ) * surface.colour
    }

    /// A colour of `material` at `uv` from its constant and map: see
    /// [`reflectance`](Self::reflectance), or, where factors multiply maps (glTF), the
    /// constant times the map's value clamped to [0, 1].
    #[inline]
    fn colour(&self, material: &Material, map: Option<u32>, constant: Vec3, uv: Vec2) -> Vec3 {
        match map {
            Some(t) if material.factors_multiply_maps() => {
                constant * self.texture(t).sample(uv).clamp(Vec3::ZERO, Vec3::ONE)
            }
            _ => self.reflectance(map, constant, uv),
        }
    }

    /// A reflectance colour at `uv`: its map's value clamped to [0, 1] like the
    /// constant, or the constant where there is no map.
    #[inline]
    fn reflectance(&self, map: Option<u32>, constant: Vec3, uv: Vec2) -> Vec3 {
        match map {
            Some(t) => self.texture(t).sample(uv).clamp(Vec3::ZERO, Vec3::ONE),
            None => constant,
        }
    }

    /// What the material is at a surface point, its maps read.
    #[inline]
    pub fn params(&self, surface: &SurfacePoint) -> SurfaceParams {
        let material = self.material(surface);
        let maps = &material.maps;
        let scalar = |map: Option<u32>, channel: Channel| {
            map.map(|t| channel.of(self.texture(t).sample(surface.uv)))
        };
        let albedo = if material.uses_albedo() {
            self.albedo(surface)
        } else {
            Vec3::ZERO
        };
        let specular = self.colour(material, maps.specular, material.specular, surface.uv);
        let metallic = match scalar(maps.metallic, maps.metallic_channel) {
            Some(m) => material.metallic * m,
            None => material.metallic,
        };
        let roughness = scalar(maps.roughness, maps.roughness_channel);
        let shininess = scalar(maps.shininess, Channel::Red);
        let transmission = match material.model {
            Model::MetallicRoughness { transmission, .. } if transmission > 0.0 => {
                let map = scalar(maps.transmission, Channel::Red).unwrap_or(1.0);
                (transmission * map).clamp(0.0, 1.0)
            }
            _ => 0.0,
        };
        SurfaceParams {
            albedo,
            specular,
            alpha: material.alpha_at(roughness, shininess),
            metallic: metallic.clamp(0.0, 1.0),
            transmission,
        }
    }

    /// The BSDF of the surface at a hit point, seen from direction `wo`.
    #[inline]
    pub fn bsdf(&self, surface: &SurfacePoint, wo: Vec3) -> Bsdf {
        let material = self.material(surface);
        let ns = if material.maps.perturbs_normal() {
            keep_reflection_above(surface.ns, surface.ng, wo)
        } else {
            surface.ns
        };
        material.bsdf(&self.params(surface), ns, surface.ng)
    }

    /// Radiance emitted at a surface point (on its emitting side): `Ke`, times `map_Ke`
    /// where there is one.
    #[inline]
    pub fn emitted(&self, surface: &SurfacePoint) -> Vec3 {
        let material = self.material(surface);
        match material.maps.emission {
            Some(t) => material.emission * self.texture(t).sample(surface.uv).max(Vec3::ZERO),
            None => material.emission,
        }
    }

    /// The hit filter of the scene's cut-outs, or `None` when every material is opaque.
    pub fn opacity(&self) -> Option<Arc<Opacity>> {
        Opacity::of(self)
    }

    pub fn bounds(&self) -> (Vec3, Vec3) {
        match &self.instancing {
            None => self.mesh.bounds(),
            Some(instancing) => instancing.bounds(),
        }
    }

    /// Radius of the sphere around the bounding box.
    pub fn bounding_radius(&self) -> f32 {
        let (lo, hi) = self.bounds();
        let radius = 0.5 * (hi - lo).length();
        if radius.is_finite() {
            radius
        } else {
            0.0
        }
    }

    /// Radiance arriving along a ray that leaves the scene in direction `dir`.
    #[inline]
    pub fn sky_radiance(&self, dir: Vec3) -> Vec3 {
        self.sky
            .as_ref()
            .map_or(Vec3::ZERO, |sky| sky.radiance(dir))
    }
}
