//! A block of [`W`] paths traced together from the camera to the film: their state in
//! lanes, and the stages each bounce runs over all of them (surface and emission, light
//! sample and shadow packet, roulette, BSDF sample and the next packet of rays).
//!
//! A lane whose path ends takes the next camera sample at once, so the stages keep all
//! lanes busy until the work runs out: new samples are started [`W`] at a time (their
//! camera rays, consecutive samples of one pixel or a row of pixels, traced as one
//! coherent packet) and moved one by one into the lanes that free up. Lanes are then at
//! different vertices; what depends on the vertex (the camera ray's full weight, the
//! first vertex's stratified draws, the last vertex, roulette) is chosen per lane.
//!
//! The estimator is the scalar loop's `mis` on Lambertian surfaces: next-event
//! estimation and a cosine-weighted BSDF sample at every vertex, weighted by the power
//! heuristic; the last vertex takes its light sample alone (weight 1) and traces no
//! BSDF ray; Russian roulette from [`ROULETTE_START_VERTEX`].

use std::f32::consts::FRAC_1_PI;

use super::lanes::{map, F32s, Mask, U32s, Vec3s, W};
use super::math::sincos_turns;
use super::rng::{Draw, Pcg32s, SobolLanes};
use super::Wavefront;
use crate::accel::{Accel, Hits16, Rays16};
use crate::geometry::{gamma, SHADOW_EPSILON, SPAWN_TMIN};
use crate::integrator::ROULETTE_START_VERTEX;
use crate::sampling::ONE_BELOW;

/// One camera sample: its pixel and its index among the pixel's samples.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CameraSample {
    pub x: u32,
    pub y: u32,
    pub sample: u32,
}

/// The state of [`W`] paths, a lane each.
#[derive(Clone, Copy)]
struct Paths {
    rays: Rays16,
    hits: Hits16,
    alive: Mask,
    /// The vertex each lane's ray goes to: 1 for the camera ray's.
    segment: U32s,
    /// Where each lane's radiance goes when its path ends.
    slot: U32s,
    throughput: Vec3s,
    radiance: Vec3s,
    /// The density with which the BSDF chose each lane's current ray (the MIS weight of
    /// the emitter it meets needs it); not read for camera rays.
    bsdf_pdf: F32s,
    pcg: Pcg32s,
    /// The first vertex's stratified draws: a light sample's pair, then the BSDF's.
    first_vertex: [F32s; 4],
}

/// A lane's hit as shading needs it.
struct Surface {
    p: Vec3s,
    /// Per-axis bound on the rounding error of `p`.
    error: Vec3s,
    /// Unit geometric normal, on the side of the incoming ray.
    n: Vec3s,
    albedo: Vec3s,
}

/// A light sample per lane: the shadow packet and what an unblocked lane adds.
struct LightSamples {
    shadow: Rays16,
    valid: Mask,
    contribution: Vec3s,
}

/// Camera samples started together, whose lanes are moved one by one into the lanes of
/// the paths that end.
struct Fresh {
    paths: Paths,
    /// Lanes started, and lanes already moved.
    len: usize,
    taken: usize,
}

impl Paths {
    /// No paths.
    fn empty() -> Paths {
        Paths {
            rays: Rays16::default(),
            hits: Hits16::default(),
            alive: Mask::NONE,
            segment: U32s::splat(0),
            slot: U32s::splat(0),
            throughput: Vec3s::ONE,
            radiance: Vec3s::ZERO,
            bsdf_pdf: F32s::ZERO,
            pcg: Pcg32s::default(),
            first_vertex: [F32s::ZERO; 4],
        }
    }

    /// Lane `l` becomes lane `k` of `from`.
    fn take_lane(&mut self, l: usize, from: &Paths, k: usize) {
        self.rays.set(l, &from.rays.ray(k));
        self.hits.set(l, from.hits.hit(k));
        self.alive.0[l] = from.alive.0[k];
        self.segment.0[l] = from.segment.0[k];
        self.slot.0[l] = from.slot.0[k];
        for (to, from) in [
            (&mut self.throughput, &from.throughput),
            (&mut self.radiance, &from.radiance),
        ] {
            to.x.0[l] = from.x.0[k];
            to.y.0[l] = from.y.0[k];
            to.z.0[l] = from.z.0[k];
        }
        self.bsdf_pdf.0[l] = from.bsdf_pdf.0[k];
        self.pcg.take_lane(l, &from.pcg, k);
        for (to, from) in self.first_vertex.iter_mut().zip(&from.first_vertex) {
            to.0[l] = from.0[k];
        }
    }
}

impl<A: Accel> Wavefront<'_, A> {
    /// The radiance of every camera sample of `work`, into `out` (sample `i` into
    /// `out[i]`); the rays traced.
    #[inline(always)]
    pub fn trace(&self, work: &[CameraSample], out: &mut [glam::Vec3]) -> u64 {
        let mut rays = 0;
        let mut queue = work.chunks(W).enumerate();
        let mut fresh = Fresh {
            paths: Paths::empty(),
            len: 0,
            taken: 0,
        };
        let mut paths = Paths::empty();
        loop {
            for l in 0..W {
                if paths.alive.0[l] {
                    continue;
                }
                if fresh.taken == fresh.len {
                    let Some((block, samples)) = queue.next() else {
                        break;
                    };
                    fresh = self.start(samples, (block * W) as u32);
                    rays += u64::from(fresh.paths.alive.count());
                }
                paths.take_lane(l, &fresh.paths, fresh.taken);
                fresh.taken += 1;
            }
            if !paths.alive.any() {
                return rays;
            }
            rays += self.bounce(&mut paths, out);
        }
    }

    /// New paths for up to [`W`] camera samples, whose radiance goes to the slots
    /// from `first_slot` on: their rays through uniform points of their pixels (a box
    /// filter), traced as one packet, and each lane's random streams.
    #[inline(always)]
    fn start(&self, samples: &[CameraSample], first_slot: u32) -> Fresh {
        let mut paths = Paths::empty();
        let mut sobol = SobolLanes::default();
        let (mut x, mut y) = (U32s::splat(0), U32s::splat(0));
        let (mut pixels, mut indices) = ([0u64; W], [0u64; W]);
        for (l, s) in samples.iter().enumerate() {
            pixels[l] = u64::from(s.y) * u64::from(self.image_width) + u64::from(s.x);
            indices[l] = u64::from(s.sample);
            (x.0[l], y.0[l]) = (s.x, s.y);
            paths.slot.0[l] = first_slot + l as u32;
        }
        paths.pcg.seed_samples(self.seed, &pixels, &indices);
        sobol.seed_samples(self.seed, &pixels, &indices);
        paths.alive = Mask::first(samples.len());
        paths.segment = U32s::splat(1);
        let [dx, dy] = sobol.pair(Draw::Camera, &mut paths.pcg);
        let [l1, l2] = sobol.pair(Draw::Light, &mut paths.pcg);
        let [b1, b2] = sobol.pair(Draw::Bsdf, &mut paths.pcg);
        paths.first_vertex = [l1, l2, b1, b2];
        let c = &self.camera;
        let sx = (2.0 * (x.to_f32() + dx)) / c.width - 1.0;
        let sy = 1.0 - (2.0 * (y.to_f32() + dy)) / c.height;
        let infinity = F32s::splat(f32::INFINITY);
        let eye = Vec3s::splat(c.eye);
        let (origin, dir) = if c.parallel {
            let offset = Vec3s::splat(c.right).scale(sx) + Vec3s::splat(c.up).scale(sy);
            (eye + offset, Vec3s::splat(c.forward))
        } else {
            let dir = Vec3s::splat(c.forward)
                + Vec3s::splat(c.right).scale(sx)
                + Vec3s::splat(c.up).scale(sy);
            (eye, normalize(dir))
        };
        set_rays(&mut paths.rays, origin, dir, F32s::ZERO, infinity);
        self.accel
            .intersect16(&paths.alive.0, &paths.rays, &mut paths.hits, true);
        Fresh {
            paths,
            len: samples.len(),
            taken: 0,
        }
    }

    /// One vertex of every live path: the emission its ray met, a light sample, then
    /// roulette and the BSDF's direction, and the next ray traced. A path that ends
    /// writes its radiance to its slot of `out`. Returns the rays traced.
    #[inline(always)]
    fn bounce(&self, paths: &mut Paths, out: &mut [glam::Vec3]) -> u64 {
        let started = paths.alive;
        let segment = paths.segment;
        paths.alive = paths.alive & Mask(paths.hits.found);
        let surface = self.surface(paths);
        self.add_emission(paths, segment);
        paths.alive = paths.alive & segment.lt(U32s::splat(self.max_depth));
        let first = segment.eq(U32s::splat(1));
        let last = segment.eq(U32s::splat(self.max_depth.saturating_sub(1)));
        // Every lane draws the same numbers from its stream at every vertex, so a
        // path's numbers do not depend on the lanes beside it.
        let light_u = [paths.pcg.f32(), paths.pcg.f32()];
        let coin = paths.pcg.f32();
        let bsdf_u = [paths.pcg.f32(), paths.pcg.f32()];
        let fv = paths.first_vertex;
        let light_u = [
            first.select(fv[0], light_u[0]),
            first.select(fv[1], light_u[1]),
        ];
        let bsdf_u = [
            first.select(fv[2], bsdf_u[0]),
            first.select(fv[3], bsdf_u[1]),
        ];
        let light = self.light_samples(paths, &surface, light_u, last);
        let blocked = self.accel.occluded16(&light.valid.0, &light.shadow);
        let lit = light.valid & !Mask(blocked);
        paths.radiance += Vec3s::select(lit, light.contribution, Vec3s::ZERO);
        paths.alive = paths.alive & !last;
        roulette(paths, coin);
        bsdf_step(paths, &surface, bsdf_u);
        paths.segment = U32s(map(segment.0, |s| s + 1));
        self.accel
            .intersect16(&paths.alive.0, &paths.rays, &mut paths.hits, false);
        let ended = started & !paths.alive;
        for l in 0..W {
            if ended.0[l] {
                out[paths.slot.0[l] as usize] = paths.radiance.lane(l);
            }
        }
        u64::from(light.valid.count()) + u64::from(paths.alive.count())
    }

    /// The hit point, its error bound, the normal facing the ray and the albedo.
    #[inline(always)]
    fn surface(&self, paths: &Paths) -> Surface {
        let s = self.scene;
        let prim = U32s(paths.hits.prim);
        let (u, v) = (F32s(paths.hits.u), F32s(paths.hits.v));
        let w = 1.0 - u - v;
        let [a, b, c] = gather_corners(&s.corners, prim);
        let p = a.scale(w) + b.scale(u) + c.scale(v);
        let error = barycentric_error([w, u, v], [a, b, c]);
        let ng = Vec3s::gather(&s.normal, prim);
        let incoming = ray_dir(&paths.rays);
        let n = Vec3s::select(incoming.dot(ng).gt(F32s::ZERO), -ng, ng);
        Surface {
            p,
            error,
            n,
            albedo: Vec3s::gather(&s.albedo, prim),
        }
    }

    /// Adds the light of the emitters the lanes' rays met on their emitting side: in
    /// full for camera rays, else weighted by MIS against light sampling.
    #[inline(always)]
    fn add_emission(&self, paths: &mut Paths, segment: U32s) {
        let prim = U32s(paths.hits.prim);
        let emission = Vec3s::gather(&self.scene.emission, prim);
        let emits = paths.alive & emission.max_element().gt(F32s::ZERO);
        if !emits.any() {
            return;
        }
        let ng = Vec3s::gather(&self.scene.normal, prim);
        let dir = ray_dir(&paths.rays);
        let cos_light = -dir.dot(ng);
        let front = emits & cos_light.gt(F32s::ZERO);
        let t = F32s(paths.hits.t);
        let light_pdf = F32s::gather(&self.scene.light_density, prim) * t * t / cos_light;
        let camera_ray = segment.eq(U32s::splat(1));
        let weight = camera_ray.select(F32s::ONE, power_heuristic(paths.bsdf_pdf, light_pdf));
        let added = (paths.throughput * emission).scale(weight);
        paths.radiance += Vec3s::select(front, added, Vec3s::ZERO);
    }

    /// One light sample per lane: an emitter from the alias table, a uniform point on
    /// it, its shadow ray and the radiance it brings if unblocked (with its MIS weight
    /// against the BSDF's density, or weight 1 at the last vertex).
    #[inline(always)]
    fn light_samples(
        &self,
        paths: &Paths,
        surface: &Surface,
        [u1, u2]: [F32s; 2],
        last_vertex: Mask,
    ) -> LightSamples {
        let e = &self.scene.emitters;
        let (emitter, u1) = alias_draw(&e.keep, &e.alias, u1);
        let s = u1.sqrt();
        let (b1, b2) = (s * (1.0 - u2), s * u2);
        let [a, b, c] = gather_corners(&e.corners, emitter);
        let b0 = 1.0 - b1 - b2;
        let q = a.scale(b0) + b.scale(b1) + c.scale(b2);
        let q_error = barycentric_error([b0, b1, b2], [a, b, c]);
        let light_normal = Vec3s::gather(&e.normal, emitter);
        let to_light = q - surface.p;
        let distance_squared = to_light.length_squared();
        let wi = to_light.scale(1.0 / distance_squared.sqrt());
        let cos_light = -wi.dot(light_normal);
        let cos_surface = wi.dot(surface.n);
        let pdf = F32s::gather(&e.density, emitter) * distance_squared / cos_light;
        let weight = last_vertex.select(F32s::ONE, power_heuristic(pdf, cos_surface * FRAC_1_PI));
        let le = Vec3s::gather(&e.emission, emitter);
        let f_cos = surface.albedo.scale(cos_surface * FRAC_1_PI);
        let contribution = (paths.throughput * f_cos * le).scale(weight / pdf);
        let valid = paths.alive
            & cos_light.gt(F32s::ZERO)
            & cos_surface.gt(F32s::ZERO)
            & pdf.is_finite()
            & pdf.gt(F32s::ZERO);
        // Both ends leave their surfaces: the shadow segment runs between the offset
        // points and stops short of the far one.
        let from = offset_towards(surface.p, surface.error, surface.n, to_light);
        let end = offset_towards(q, q_error, light_normal, from - q);
        let mut shadow = Rays16::default();
        set_rays(
            &mut shadow,
            from,
            end - from,
            F32s::splat(SPAWN_TMIN),
            F32s::splat(1.0 - SHADOW_EPSILON),
        );
        LightSamples {
            shadow,
            valid,
            contribution,
        }
    }
}

/// Russian roulette from [`ROULETTE_START_VERTEX`]: a lane survives with probability
/// `min(max throughput, 0.95)` (decided by `coin`), and its throughput is divided by it.
#[inline(always)]
fn roulette(paths: &mut Paths, coin: F32s) {
    let plays = paths.segment.ge(U32s::splat(ROULETTE_START_VERTEX));
    let survive = plays.select(
        paths.throughput.max_element().min(F32s::splat(0.95)),
        F32s::ONE,
    );
    paths.alive = paths.alive & coin.lt(survive);
    paths.throughput = paths.throughput.scale(1.0 / survive);
}

/// A cosine-weighted direction about each lane's normal: the Lambertian lobe's own
/// sampling, whose weight `f·cos / pdf` is the albedo. The next ray leaves from the
/// offset hit point.
#[inline(always)]
fn bsdf_step(paths: &mut Paths, surface: &Surface, [u1, u2]: [F32s; 2]) {
    let (sin, cos) = sincos_turns(u1);
    let r = u2.sqrt();
    let z = (1.0 - u2).max(F32s::ZERO).sqrt();
    let (tangent, bitangent) = onb(surface.n);
    let wi = tangent.scale(cos * r) + bitangent.scale(sin * r) + surface.n.scale(z);
    paths.bsdf_pdf = z * FRAC_1_PI;
    paths.throughput *= surface.albedo;
    paths.alive = paths.alive & z.gt(F32s::ZERO) & paths.throughput.max_element().gt(F32s::ZERO);
    let origin = offset_towards(surface.p, surface.error, surface.n, wi);
    set_rays(
        &mut paths.rays,
        origin,
        wi,
        F32s::splat(SPAWN_TMIN),
        F32s::splat(f32::INFINITY),
    );
}

/// The alias table's draw from one uniform per lane: the outcome, and what is left of
/// the uniform rescaled to `[0, 1)` (so that it can place the point on the light).
#[inline(always)]
fn alias_draw(keep: &[f32], alias: &[u32], u: F32s) -> (U32s, F32s) {
    let n = keep.len() as f32;
    let scaled = u * n;
    let column = scaled.to_u32();
    let last = keep.len() as u32 - 1;
    let column = U32s(map(column.0, |c| c.min(last)));
    let fraction = scaled - column.to_f32();
    let coin = F32s::gather(keep, column);
    let stays = fraction.lt(coin);
    let outcome = stays.select_u32(column, U32s::gather(alias, column));
    let rest = stays.select(fraction / coin, (fraction - coin) / (1.0 - coin));
    (outcome, rest.max(F32s::ZERO).min(F32s::splat(ONE_BELOW)))
}

/// The rounding error bound of a point computed from barycentrics `b` of the corners
/// `v` (as [`crate::geometry::barycentric_error`]).
#[inline(always)]
fn barycentric_error(b: [F32s; 3], v: [Vec3s; 3]) -> Vec3s {
    (v[0].scale(b[0]).abs() + v[1].scale(b[1]).abs() + v[2].scale(b[2]).abs())
        .scale(F32s::splat(gamma(7)))
}

/// Each lane's triangle corners.
#[inline(always)]
fn gather_corners(corners: &[Vec<[f32; 3]>; 3], index: U32s) -> [Vec3s; 3] {
    [
        Vec3s::gather(&corners[0], index),
        Vec3s::gather(&corners[1], index),
        Vec3s::gather(&corners[2], index),
    ]
}

/// Veach's power heuristic per lane for a sample of density `a` against `b`.
#[inline(always)]
fn power_heuristic(a: F32s, b: F32s) -> F32s {
    let (a2, b2) = (a * a, b * b);
    let sum = a2 + b2;
    sum.gt(F32s::ZERO).select(a2 / sum, F32s::ZERO)
}

#[inline(always)]
fn normalize(v: Vec3s) -> Vec3s {
    v.scale(1.0 / v.length_squared().sqrt())
}

#[inline(always)]
fn ray_dir(rays: &Rays16) -> Vec3s {
    Vec3s::new(F32s(rays.dir[0]), F32s(rays.dir[1]), F32s(rays.dir[2]))
}

#[inline(always)]
fn set_rays(rays: &mut Rays16, origin: Vec3s, dir: Vec3s, tmin: F32s, tmax: F32s) {
    rays.org = [origin.x.0, origin.y.0, origin.z.0];
    rays.dir = [dir.x.0, dir.y.0, dir.z.0];
    rays.tmin = tmin.0;
    rays.tmax = tmax.0;
}

/// Duff et al.'s branchless frame about unit `n` (as [`crate::sampling::Onb`]).
#[inline(always)]
fn onb(n: Vec3s) -> (Vec3s, Vec3s) {
    let sign = F32s::ONE.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let u = Vec3s::new(1.0 + sign * n.x * n.x * a, sign * b, -(sign * n.x));
    let v = Vec3s::new(b, sign + n.y * n.y * a, -n.y);
    (u, v)
}

/// The origin of a ray leaving the surface point `p` (error bound `error`, unit normal
/// `n`) towards `dir`: moved along the normal past the error box, to `dir`'s side, and
/// rounded one ulp further (as [`crate::geometry::SurfaceOrigin::offset_towards`]).
#[inline(always)]
fn offset_towards(p: Vec3s, error: Vec3s, n: Vec3s, dir: Vec3s) -> Vec3s {
    let distance = n.abs().dot(error);
    let offset = n.scale(distance);
    let offset = Vec3s::select(dir.dot(n).lt(F32s::ZERO), -offset, offset);
    let moved = p + offset;
    Vec3s::new(
        round_away(moved.x, offset.x),
        round_away(moved.y, offset.y),
        round_away(moved.z, offset.z),
    )
}

/// `x` moved one ulp further in the direction of `offset`'s sign, per lane (as
/// [`crate::geometry::round_away`]).
#[inline(always)]
fn round_away(x: F32s, offset: F32s) -> F32s {
    let mut out = [0.0f32; W];
    for l in 0..W {
        let (x, o) = (x.0[l], offset.0[l]);
        let bits = x.to_bits();
        let away = (o > 0.0) == (x > 0.0);
        let moved = if x == 0.0 {
            f32::from_bits(1).copysign(o)
        } else if away {
            f32::from_bits(bits.wrapping_add(1))
        } else {
            f32::from_bits(bits.wrapping_sub(1))
        };
        out[l] = if o == 0.0 || !x.is_finite() { x } else { moved };
    }
    F32s(out)
}
