//! Light sampling: choosing points on the scene's emitters and directions towards its
//! sky ([`LightSampler`]), and the book's densities over directions built on it and on
//! the BSDF ([`Pdf`]: [`BsdfPdf`], [`LightPdf`], [`MixturePdf`]).

mod pdf;
mod sampler;

pub use pdf::{BsdfPdf, Direction, LightPdf, MixturePdf, Pdf};
pub use sampler::{LightSample, LightSampler, LightTarget};
