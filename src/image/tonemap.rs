//! From linear radiance to 8-bit display values: an exposure in stops, then a tone
//! curve. Only 8-bit outputs (PNG) are tone-mapped; EXR and HDR keep linear radiance.
//!
//! - `clip`: sRGB encoding of the exposed value, clipped at 1 (the default: images
//!   made before tone mapping existed are unchanged).
//! - `aces`: Narkowicz's fit of the ACES filmic curve, then sRGB encoding.
//! - `agx`: Troy Sobotka's AgX with its default look, in Benjamin Wrensch's minimal
//!   polynomial form: inset matrix, log2 encoding over 16.5 stops, sigmoid, outset
//!   matrix; its output is already display-encoded.

use glam::{Mat3, Vec3};

use super::linear_to_srgb;

/// Which curve maps exposed radiance to the display.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ToneCurve {
    #[default]
    Clip,
    Aces,
    Agx,
}

/// How 8-bit outputs are made from linear radiance.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Tonemap {
    /// Exposure in stops: radiance is multiplied by `2^exposure` first.
    pub exposure: f32,
    pub curve: ToneCurve,
}

impl Tonemap {
    /// The display value in [0, 1] of linear radiance `c`, per channel.
    pub fn display(&self, c: Vec3) -> Vec3 {
        let c = (c * self.exposure.exp2()).max(Vec3::ZERO);
        let encoded: Vec3 = match self.curve {
            ToneCurve::Clip => c.to_array().map(linear_to_srgb).into(),
            ToneCurve::Aces => aces(c).to_array().map(linear_to_srgb).into(),
            ToneCurve::Agx => agx(c),
        };
        encoded.clamp(Vec3::ZERO, Vec3::ONE)
    }

    /// `display`, quantised to 8 bits with rounding.
    pub fn to_u8(&self, c: Vec3) -> [u8; 3] {
        self.display(c).to_array().map(|v| (v * 255.0 + 0.5) as u8)
    }
}

/// Narkowicz (2015): `x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14)`.
fn aces(x: Vec3) -> Vec3 {
    (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)
}

/// AgX's default contrast curve, a 6th-order fit of its sigmoid on [0, 1].
fn agx_contrast(x: f32) -> f32 {
    let x2 = x * x;
    let x4 = x2 * x2;
    15.5 * x4 * x2 - 40.14 * x4 * x + 31.96 * x4 - 6.868 * x2 * x + 0.4298 * x2 + 0.1191 * x
        - 0.00232
}

fn agx(c: Vec3) -> Vec3 {
    const MIN_EV: f32 = -12.47393;
    const MAX_EV: f32 = 4.026069;
    let inset = Mat3::from_cols(
        Vec3::new(0.842_479_06, 0.042_328_242, 0.042_375_655),
        Vec3::new(0.078_433_6, 0.878_468_6, 0.078_433_6),
        Vec3::new(0.079_223_745, 0.079_166_13, 0.879_143),
    );
    let outset = Mat3::from_cols(
        Vec3::new(1.196_879, -0.052_896_852, -0.052_971_635),
        Vec3::new(-0.098_020_88, 1.151_903_1, -0.098_043_45),
        Vec3::new(-0.099_029_74, -0.098_961_18, 1.151_073_7),
    );
    let v = inset * c;
    let log = v
        .to_array()
        .map(|x| (x.max(1e-10).log2().clamp(MIN_EV, MAX_EV) - MIN_EV) / (MAX_EV - MIN_EV));
    outset * Vec3::from(log.map(agx_contrast))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clip_is_srgb_and_clips_at_one() {
        let t = Tonemap::default();
        assert_eq!(t.to_u8(Vec3::new(0.0, 1.0, 7.0)), [0, 255, 255]);
        // Exactly the sRGB encoding of each value, rounded, as before tone mapping.
        for x in [0.001f32, 0.05, 0.214, 0.5, 0.9] {
            let want = (linear_to_srgb(x) * 255.0 + 0.5) as u8;
            assert_eq!(t.to_u8(Vec3::splat(x)), [want; 3], "{x}");
        }
        // One stop up doubles the radiance first.
        let up = Tonemap { exposure: 1.0, ..t };
        assert_eq!(up.to_u8(Vec3::splat(0.107)), t.to_u8(Vec3::splat(0.214)));
    }

    #[test]
    fn filmic_curves_are_monotonic_and_roll_off() {
        for curve in [ToneCurve::Aces, ToneCurve::Agx] {
            let t = Tonemap {
                exposure: 0.0,
                curve,
            };
            let mut previous = -1.0;
            for i in 0..200 {
                let x = 10f32.powf(-3.0 + i as f32 * 0.03);
                let y = t.display(Vec3::splat(x)).x;
                assert!(y >= previous - 1e-4, "{curve:?} falls at {x}");
                previous = y;
            }
            // Black stays (nearly) black, mid grey stays mid, and highlights roll off
            // below 1 instead of clipping at once.
            assert!(t.display(Vec3::ZERO).x < 0.02, "{curve:?}");
            let grey = t.display(Vec3::splat(0.18)).x;
            assert!((0.3..0.7).contains(&grey), "{curve:?}: grey {grey}");
            assert!(t.display(Vec3::splat(2.0)).x < 1.0, "{curve:?}");
        }
    }
}
