//! Light sampling: choosing points on the scene's emitters and directions towards its
//! sky ([`LightSampler`]), and the book's densities over directions built on it and on
//! the BSDF ([`Pdf`]: [`BsdfPdf`], [`LightPdf`], [`MixturePdf`]).
//!
//! An emitter is chosen by an alias table (then a uniform point on its area: the
//! default with fewer than [`BVH_MIN_EMITTERS`] emitters) or by a light BVH ([`bvh`]:
//! the default from there on); with the BVH or `--light-sampler solid-angle`, a
//! direction towards it by solid angle ([`spherical_triangle`]) or by area, as
//! [`emitter`]'s rule decides.
//!
//! The scene's point and spot lights are chosen with the emitters (by the same table
//! or tree, by power), its suns with the sky ([`placed`]). Point lights and suns
//! without a disc are delta lights: only light samples reach them, with MIS weight 1.

pub mod bvh;
mod emitter;
mod pdf;
pub mod placed;
mod sampler;
pub mod spherical_triangle;

pub use emitter::{Receiver, MAX_SOLID_ANGLE, MIN_SOLID_ANGLE};
pub use pdf::{BsdfPdf, Direction, GuidedLightPdf, LightPdf, MixturePdf, Pdf};
pub use sampler::{
    GuidedLightDraw, LightSample, LightSampler, LightSamplerKind, LightTarget, SkyGuide,
    BVH_MIN_EMITTERS,
};
