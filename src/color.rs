//! Colour helpers shared by materials, lights and images.

use glam::Vec3;

/// The mean of the three channels: what the guide learns from and adjoint-driven
/// roulette weighs, where every channel counts alike.
#[inline]
pub fn channel_mean(c: Vec3) -> f32 {
    (c.x + c.y + c.z) / 3.0
}

/// Perceived brightness of linear RGB (Rec. 709 weights).
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}
