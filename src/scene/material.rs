//! Materials read from MTL files, and what a surface does with light that reaches it.
//!
//! How MTL statements map to a material (first rule that applies):
//! - `illum` 4, 6, 7 or 9, or `d` < 1, or `Tr` > 0: **glass** (dielectric) with index `Ni`
//!   (1.5 when `Ni` is absent or ≤ 1).
//! - `illum` 3 or 5, or `Ks` > 0 with a black `Kd`: **metal** with reflectance `Ks` and
//!   roughness from the Phong exponent, `fuzz = sqrt(2 / (Ns + 2))`.
//! - `Kd` and `Ks` both non-zero: **plastic**, a diffuse base with a glossy coat; each
//!   scattering picks one lobe in proportion to its brightness.
//! - otherwise **diffuse** (Lambertian) with albedo `Kd`, or `map_Kd` when given.
//!
//! Any material with `Ke` > 0 also emits `Ke` from the side its triangles' winding
//! normal points to. Diffuse surfaces are two-sided: hit from behind, they reflect like
//! their front.

use glam::{Vec2, Vec3};

use crate::sampling::{luminance, uniform_sphere, Rng};

/// How a material scatters light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bsdf {
    Diffuse,
    Metal {
        fuzz: f32,
    },
    Glass {
        ior: f32,
    },
    /// Diffuse base plus a glossy coat, chosen with probability `coat_probability`.
    Plastic {
        fuzz: f32,
        coat_probability: f32,
    },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// `Kd`: diffuse reflectance (linear RGB).
    pub diffuse: Vec3,
    /// `map_Kd`: index into the scene's textures, replacing `Kd` where present.
    pub diffuse_texture: Option<u32>,
    /// `Ks`: specular reflectance of metal and plastic coats.
    pub specular: Vec3,
    /// `Ke`: emitted radiance.
    pub emission: Vec3,
    pub bsdf: Bsdf,
}

impl Default for Material {
    /// Matte grey, for triangles without a material.
    fn default() -> Self {
        Material {
            name: "default".into(),
            diffuse: Vec3::splat(0.5),
            diffuse_texture: None,
            specular: Vec3::ZERO,
            emission: Vec3::ZERO,
            bsdf: Bsdf::Diffuse,
        }
    }
}

/// The raw MTL values a [`Material`] is made from.
#[derive(Clone, Debug, Default)]
pub struct MtlValues {
    pub kd: Option<Vec3>,
    pub ks: Option<Vec3>,
    pub ke: Option<Vec3>,
    pub ns: Option<f32>,
    pub ni: Option<f32>,
    pub d: Option<f32>,
    pub tr: Option<f32>,
    pub illum: Option<u8>,
}

impl Material {
    /// Applies the mapping rules in the module documentation.
    pub fn from_mtl(name: &str, mtl: &MtlValues, diffuse_texture: Option<u32>) -> Material {
        let kd = mtl.kd.unwrap_or(Vec3::ZERO).max(Vec3::ZERO);
        let ks = mtl.ks.unwrap_or(Vec3::ZERO).max(Vec3::ZERO);
        let ke = mtl.ke.unwrap_or(Vec3::ZERO).max(Vec3::ZERO);
        let fuzz = (2.0 / (mtl.ns.unwrap_or(0.0).max(0.0) + 2.0)).sqrt();
        let illum = mtl.illum.unwrap_or(2);
        let transparent = mtl.d.is_some_and(|d| d < 1.0) || mtl.tr.is_some_and(|t| t > 0.0);
        let bsdf = if matches!(illum, 4 | 6 | 7 | 9) || transparent {
            Bsdf::Glass {
                ior: mtl.ni.filter(|&n| n > 1.0).unwrap_or(1.5),
            }
        } else if matches!(illum, 3 | 5)
            || (ks.max_element() > 0.0 && kd.max_element() == 0.0 && diffuse_texture.is_none())
        {
            Bsdf::Metal { fuzz }
        } else if ks.max_element() > 0.0 && (kd.max_element() > 0.0 || diffuse_texture.is_some()) {
            let (coat, base) = (luminance(ks), luminance(kd).max(1e-3));
            Bsdf::Plastic {
                fuzz,
                coat_probability: (coat / (coat + base)).clamp(0.05, 0.95),
            }
        } else {
            Bsdf::Diffuse
        };
        Material {
            name: name.to_owned(),
            diffuse: kd,
            diffuse_texture,
            specular: ks,
            emission: ke,
            bsdf,
        }
    }

    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }
}

/// What happens to light arriving along `-wo` at a surface, decided by one random draw.
#[derive(Clone, Copy, Debug)]
pub enum Scatter {
    /// A Lambertian lobe with this albedo around the shading normal `normal` (facing
    /// the incoming ray). The integrator chooses how to sample it (cosine, lights, …).
    Diffuse { albedo: Vec3, normal: Vec3 },
    /// A specular (delta or fuzzy) bounce: continue along `dir` with `weight`
    /// (BSDF × cosine / probability, already divided out). Bypasses the PDFs.
    Specular { dir: Vec3, weight: Vec3 },
}

/// Reflects `d` about the unit normal `n`.
#[inline]
fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

/// Schlick's approximation to the Fresnel reflectance.
#[inline]
fn schlick(cos: f32, eta_ratio: f32) -> f32 {
    let r0 = ((1.0 - eta_ratio) / (1.0 + eta_ratio)).powi(2);
    r0 + (1.0 - r0) * (1.0 - cos).powi(5)
}

/// A mirror direction roughened by `fuzz` as in "Ray Tracing in One Weekend", pushed
/// back above the surface if the roughening sent it below.
fn fuzzy_reflection(dir: Vec3, normal: Vec3, fuzz: f32, rng: &mut Rng) -> Vec3 {
    let mirrored = reflect(dir, normal);
    if fuzz <= 0.0 {
        return mirrored;
    }
    let (u1, u2) = rng.pair();
    let jitter = uniform_sphere(u1, u2) * rng.f32().cbrt();
    let out = (mirrored + fuzz * jitter).normalize_or_zero();
    if out.dot(normal) > 1e-4 {
        out
    } else {
        mirrored
    }
}

impl Material {
    /// Chooses how light scatters at a surface hit by a ray travelling along unit `dir`.
    /// `ng`/`ns` are the unit geometric and shading normals (same side); `albedo` is the
    /// (possibly textured) diffuse reflectance there.
    pub fn scatter(&self, dir: Vec3, ng: Vec3, ns: Vec3, albedo: Vec3, rng: &mut Rng) -> Scatter {
        let front = dir.dot(ng) < 0.0;
        // Shading normal on the side the ray came from (two-sided surfaces).
        let facing = if front { ns } else { -ns };
        match self.bsdf {
            Bsdf::Diffuse => Scatter::Diffuse {
                albedo,
                normal: facing,
            },
            Bsdf::Metal { fuzz } => Scatter::Specular {
                dir: fuzzy_reflection(dir, facing, fuzz, rng),
                weight: self.specular,
            },
            Bsdf::Plastic {
                fuzz,
                coat_probability,
            } => {
                if rng.f32() < coat_probability {
                    Scatter::Specular {
                        dir: fuzzy_reflection(dir, facing, fuzz, rng),
                        weight: self.specular / coat_probability,
                    }
                } else {
                    Scatter::Diffuse {
                        albedo: albedo / (1.0 - coat_probability),
                        normal: facing,
                    }
                }
            }
            Bsdf::Glass { ior } => {
                let eta_ratio = if front { 1.0 / ior } else { ior };
                let cos_i = (-dir).dot(facing).min(1.0);
                let sin_t2 = eta_ratio * eta_ratio * (1.0 - cos_i * cos_i);
                let reflect_it = sin_t2 > 1.0 || rng.f32() < schlick(cos_i, eta_ratio);
                let out = if reflect_it {
                    reflect(dir, facing)
                } else {
                    let perp = eta_ratio * (dir + cos_i * facing);
                    perp - (1.0 - sin_t2).max(0.0).sqrt() * facing
                };
                Scatter::Specular {
                    dir: out.normalize(),
                    weight: Vec3::ONE,
                }
            }
        }
    }
}

/// An RGB texture in linear colour, looked up with wrapping and bilinear filtering.
#[derive(Clone, Debug)]
pub struct Texture {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<Vec3>,
}

impl Texture {
    /// The colour at `uv`; `(0, 0)` is the bottom-left of the image (OBJ convention).
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        let (w, h) = (self.width as f32, self.height as f32);
        let x = uv.x.rem_euclid(1.0) * w - 0.5;
        let y = (1.0 - uv.y.rem_euclid(1.0)) * h - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return Vec3::ZERO;
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let texel = |xi: f32, yi: f32| {
            let xi = (xi as i64).rem_euclid(self.width as i64) as usize;
            let yi = (yi as i64).rem_euclid(self.height as i64) as usize;
            self.texels[yi * self.width as usize + xi]
        };
        let top = texel(x0, y0).lerp(texel(x0 + 1.0, y0), fx);
        let bottom = texel(x0, y0 + 1.0).lerp(texel(x0 + 1.0, y0 + 1.0), fx);
        top.lerp(bottom, fy)
    }
}
