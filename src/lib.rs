//! ember: a physically based CPU path tracer for OBJ scenes, with Intel Embree (through
//! FFI) or a native Rust BVH answering the ray queries.
//!
//! Data flows one way: [`scene`] loads an OBJ into an immutable [`scene::Scene`]; an
//! [`accel::Accel`] (Embree, or the native BVH) answers ray queries against its
//! triangles; the [`integrator`] estimates radiance per camera sample; [`render`] spreads
//! the samples over threads into a [`film::Film`] (sums and counts per pixel, which
//! checkpoints and shards store and merge), which resolves to an [`image::Image`],
//! written as PNG, EXR or HDR.

#![deny(unsafe_code)]

pub mod accel;
pub mod bsdf;
pub mod color;
pub mod denoise;
// The only unsafe code: the FFI to Embree, each block with its SAFETY line.
#[allow(unsafe_code)]
pub mod embree;
pub mod film;
pub mod geometry;
pub mod guiding;
pub mod image;
pub mod integrator;
pub mod io;
pub mod light;
pub mod limits;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod wavefront;
