//! Transcendental functions on lanes: polynomials instead of libm calls, which would
//! leave the loop scalar. Each states its error and a test holds it to that.

use super::lanes::F32s;
#[cfg(test)]
use super::lanes::W;

/// `sin(2πs)/s` on `s ∈ [−1/4, 1/4]`, as a polynomial in `s²` (lowest power first),
/// fitted by `scripts/fit_sincos.py`.
const SIN: [f32; 5] = [6.283_185_5, -41.341_682, 81.602_486, -76.581_4, 39.761_616];

/// `cos(2πs)` on the same interval, in `s²`.
const COS: [f32; 6] = [
    1.0,
    -19.739_208,
    64.939_35,
    -85.453_575,
    60.144_016,
    -24.982_237,
];

/// Largest absolute error of [`sincos_turns`] against the exact values, on any input
/// in `[0, 1)`: the polynomials' own error is below 1e-8, the rest is `f32` rounding.
pub const SINCOS_MAX_ERROR: f32 = 3.0e-7;

#[inline(always)]
fn horner<const N: usize>(c: [f32; N], z: F32s) -> F32s {
    let mut r = F32s::splat(c[N - 1]);
    for &k in c[..N - 1].iter().rev() {
        r = r * z + k;
    }
    r
}

/// `(sin 2πu, cos 2πu)` per lane: `u` in turns (`u ∈ [0, 1)` from a uniform draw).
/// The angle is folded into `[−π/2, π/2]` by symmetry (`sin(π − x) = sin x`,
/// `cos(π − x) = −cos x`), where the polynomials hold.
#[inline(always)]
pub fn sincos_turns(u: F32s) -> (F32s, F32s) {
    // t in [−1/2, 1/2]: the same angle, whole turns removed.
    let t = u - (u + 0.5).floor();
    let magnitude = t.abs();
    let folds = magnitude.gt(F32s::splat(0.25));
    let s = folds.select((0.5 - magnitude).copysign(t), t);
    let cos_sign = folds.select(F32s::splat(-1.0), F32s::ONE);
    let z = s * s;
    (s * horner(SIN, z), cos_sign * horner(COS, z))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every input on a fine grid of `[0, 1)`, the quadrant boundaries and the values
    /// just below 1 included, is within the stated error in both functions.
    #[test]
    fn sincos_is_within_its_stated_error() {
        let n = 1 << 20;
        let mut worst = 0.0f64;
        let inputs: Vec<f32> = (0..n)
            .map(|i| i as f32 / n as f32)
            .chain([0.25, 0.5, 0.75, 1.0 - f32::EPSILON / 2.0, 0.125, 1e-30])
            .collect();
        for chunk in inputs.chunks(W) {
            let mut u = F32s::ZERO;
            u.0[..chunk.len()].copy_from_slice(chunk);
            let (s, c) = sincos_turns(u);
            for l in 0..chunk.len() {
                let angle = std::f64::consts::TAU * f64::from(u.0[l]);
                worst = worst
                    .max((f64::from(s.0[l]) - angle.sin()).abs())
                    .max((f64::from(c.0[l]) - angle.cos()).abs());
            }
        }
        assert!(
            worst <= f64::from(SINCOS_MAX_ERROR),
            "worst error {worst:e}"
        );
        // And the bound is not loose by orders of magnitude.
        assert!(worst > 1e-8, "worst error {worst:e}");
    }

    /// A sine and cosine of the same angle stay on the unit circle.
    #[test]
    fn sincos_stays_on_the_unit_circle() {
        let u = F32s(std::array::from_fn(|l| (l as f32 + 0.3) / W as f32));
        let (s, c) = sincos_turns(u);
        for l in 0..W {
            let r = s.0[l] * s.0[l] + c.0[l] * c.0[l];
            assert!((r - 1.0).abs() < 1e-6, "{r}");
        }
    }
}
