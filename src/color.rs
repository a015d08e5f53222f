//! Colour helpers shared by materials, lights and images.

use glam::Vec3;

/// Perceived brightness of linear RGB (Rec. 709 weights).
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}
