//! Cut-outs: which points of the scene's surfaces are there at all. A material's
//! opacity is its constant (`d`, or `1 − Tr`) times its opacity map (`map_d`, or the
//! alpha channel of `map_Kd`). [`Opacity`] answers, for an intersection with a triangle,
//! whether it is a hit; both accelerators ask it during traversal ([`HitFilter`]).
//!
//! Opacity 1 is a hit and 0 a miss. In between the surface is present with probability
//! equal to its opacity: a stochastic, unbiased cut-out. The coin is a hash of the
//! triangle and the hit's barycentrics quantised to 2⁻¹⁶ of the triangle, so it is a
//! fixed property of the surface point rather than of the ray: a camera ray, a bounce
//! and a shadow ray that meet the same point get the same answer, Embree calling the
//! filter twice for one hit gets it twice, and the image is the same at any thread
//! count and in both backends (up to the rare hit whose barycentrics the two backends
//! round into neighbouring cells). The cells are far below a pixel's footprint in any
//! sensible view, so pixels average over many independent coins.

use std::sync::Arc;

use glam::Vec2;

use super::{AlphaMap, Scene};
use crate::geometry::HitFilter;

/// Marks a triangle whose material is opaque.
const OPAQUE: u32 = u32::MAX;

/// What a material's opacity is made of.
#[derive(Clone, Copy, Debug)]
struct Layer {
    constant: f32,
    map: Option<u32>,
}

/// A triangle of a non-opaque material: its layer and its corners' texture coordinates.
#[derive(Clone, Copy, Debug)]
struct Cutout {
    layer: u32,
    uv: [Vec2; 3],
}

/// The opacity of every triangle of a scene, as a [`HitFilter`]. Holds 4 bytes per
/// triangle, 28 per triangle of a non-opaque material, and shares the alpha maps.
#[derive(Debug)]
pub struct Opacity {
    /// Per triangle: its index in `cutouts`, or `OPAQUE`.
    slot: Vec<u32>,
    cutouts: Vec<Cutout>,
    layers: Vec<Layer>,
    maps: Vec<Arc<AlphaMap>>,
}

impl Opacity {
    /// The cut-outs of `scene`, or `None` when every material is opaque (then no filter
    /// is installed at all, and opaque scenes pay nothing).
    pub fn of(scene: &Scene) -> Option<Arc<Opacity>> {
        let mut layer_of = vec![OPAQUE; scene.materials.len()];
        let mut layers = Vec::new();
        for (m, material) in scene.materials.iter().enumerate() {
            if !material.is_opaque() {
                layer_of[m] = layers.len() as u32;
                layers.push(Layer {
                    constant: material.opacity,
                    map: material.opacity_map,
                });
            }
        }
        if layers.is_empty() {
            return None;
        }
        let mesh = &scene.mesh;
        let mut slot = Vec::with_capacity(mesh.triangles.len());
        let mut cutouts = Vec::new();
        for (t, corners) in mesh.triangles.iter().enumerate() {
            let layer = layer_of[mesh.material[t] as usize];
            if layer == OPAQUE {
                slot.push(OPAQUE);
                continue;
            }
            // Without texture coordinates a triangle's are its barycentrics, as in
            // `TriangleMesh::surface`.
            let uv = if mesh.uvs.is_empty() {
                [Vec2::ZERO, Vec2::X, Vec2::Y]
            } else {
                corners.map(|i| mesh.uvs[i as usize])
            };
            slot.push(cutouts.len() as u32);
            cutouts.push(Cutout { layer, uv });
        }
        Some(Arc::new(Opacity {
            slot,
            cutouts,
            layers,
            maps: scene.alpha_maps.clone(),
        }))
    }

    /// The opacity in `[0, 1]` of triangle `prim` at barycentrics `(u, v)`.
    #[inline]
    pub fn opacity(&self, prim: u32, u: f32, v: f32) -> f32 {
        let Some(&slot) = self.slot.get(prim as usize) else {
            return 1.0;
        };
        if slot == OPAQUE {
            return 1.0;
        }
        let cutout = &self.cutouts[slot as usize];
        let layer = self.layers[cutout.layer as usize];
        match layer.map {
            Some(map) => {
                let [a, b, c] = cutout.uv;
                let uv = (1.0 - u - v) * a + u * b + v * c;
                layer.constant * self.maps[map as usize].sample(uv)
            }
            None => layer.constant,
        }
    }
}

impl HitFilter for Opacity {
    #[inline]
    fn accept(&self, prim: u32, u: f32, v: f32) -> bool {
        let alpha = self.opacity(prim, u, v);
        alpha >= 1.0 || (alpha > 0.0 && coin(prim, u, v) < alpha)
    }
}

/// The cut-outs of one part of an instanced scene's mesh ([`super::MeshPart`]), for
/// the accelerator built on that part alone: its triangle `prim` is the scene mesh's
/// `first + prim`. Every instance of the part shares it.
#[derive(Debug)]
pub struct PartOpacity {
    opacity: Arc<Opacity>,
    first: u32,
}

impl Opacity {
    /// The cut-outs of the part whose triangles start at `first`.
    pub fn part(self: &Arc<Self>, first: u32) -> Arc<PartOpacity> {
        Arc::new(PartOpacity {
            opacity: Arc::clone(self),
            first,
        })
    }
}

impl HitFilter for PartOpacity {
    #[inline]
    fn accept(&self, prim: u32, u: f32, v: f32) -> bool {
        self.opacity.accept(self.first + prim, u, v)
    }
}

/// A uniform number in `[0, 1)` fixed by the triangle and the hit's barycentrics
/// quantised to 2⁻¹⁶ (see the module documentation for why the point, not the ray).
#[inline]
pub fn coin(prim: u32, u: f32, v: f32) -> f32 {
    let cell = |x: f32| (x.clamp(0.0, 1.0) * 65536.0) as u64;
    let z = mix(mix(u64::from(prim)) ^ (cell(u) << 17) ^ cell(v));
    (z >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
}

/// SplitMix64's step and finaliser: every input bit moves every output bit.
#[inline]
fn mix(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_coin_is_uniform_and_a_function_of_the_point() {
        let n = 200_000;
        let mut below = [0u32; 10];
        for i in 0..n {
            let (u, v) = ((i % 443) as f32 / 443.0, (i / 443) as f32 / 452.0 * 0.5);
            let c = coin(i % 7, u, v);
            assert!((0.0..1.0).contains(&c));
            assert_eq!(c, coin(i % 7, u, v));
            below[(c * 10.0) as usize] += 1;
        }
        for count in below {
            let share = f64::from(count) / f64::from(n);
            assert!((share - 0.1).abs() < 0.005, "{below:?}");
        }
    }
}
