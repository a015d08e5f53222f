//! Bump and normal maps: shading normals perturbed by a texture. They change only the
//! shading normal; ray offsets and the side of a two-sided surface keep the geometric
//! normal.
//!
//! - A **bump map** (`bump`, `map_Bump`) is a height field `h(u, v)` times the `-bm`
//!   multiplier, displacing the surface along its normal: `p' = p + h n`. Then
//!   `∂p'/∂u = ∂p/∂u + (∂h/∂u) n` (dropping `h ∂n/∂u`, zero on a flat triangle and
//!   tiny for the small heights bump maps describe), likewise for `v`, and the
//!   perturbed normal is `∂p'/∂u × ∂p'/∂v`. `∂h/∂u` is a central difference one texel
//!   wide, which is exact on the bilinear interpolant's linear pieces.
//! - A **normal map** (`norm`) holds a tangent-space normal, `2·rgb − 1`, in the
//!   MikkTSpace frame: `n = normalize(x T + y B + z N)` with `B = sign · (N × T)` and
//!   the per-vertex tangents `(T, sign)` that MikkTSpace computed from the UVs
//!   ([`super::tangents`]). Green points along +v (the OpenGL/Blender convention).
//!
//! A perturbed normal can face away from a viewer that the geometric surface faces,
//! and reflection about it would send light below the surface: black patches, or
//! light through the surface. [`keep_reflection_above`] bends such a normal just
//! enough that the mirror direction of `wo` stays above the geometric surface (the fix
//! of Keller et al., "The Iray Light Transport Simulation and Rendering System", 2017,
//! §A.3). The BSDF still refuses any direction on the other side of the geometric
//! normal, so no light crosses the surface whatever the map says.

use glam::{Vec2, Vec3, Vec4};

use super::Texture;

/// `∂p/∂u` and `∂p/∂v` of the triangle with corners `p` and texture coordinates `uv`,
/// or `None` when its UVs are degenerate.
pub fn uv_derivatives(p: [Vec3; 3], uv: [Vec2; 3]) -> Option<(Vec3, Vec3)> {
    let (du1, du2) = (uv[1] - uv[0], uv[2] - uv[0]);
    let (dp1, dp2) = (p[1] - p[0], p[2] - p[0]);
    let det = du1.x * du2.y - du1.y * du2.x;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let dpdu = (du2.y * dp1 - du1.y * dp2) * inv;
    let dpdv = (du1.x * dp2 - du2.x * dp1) * inv;
    (dpdu.is_finite() && dpdv.is_finite()).then_some((dpdu, dpdv))
}

/// The normal of the bumped surface at `uv`, on the side of the unit normal `ns`;
/// `height` times `scale` is the displacement along `ns`.
pub fn bump(ns: Vec3, dpdu: Vec3, dpdv: Vec3, height: &Texture, scale: f32, uv: Vec2) -> Vec3 {
    // The frame in the plane of the shading normal (the triangle's own when they agree).
    let dpdu = dpdu - ns * ns.dot(dpdu);
    let dpdv = dpdv - ns * ns.dot(dpdv);
    let (du, dv) = (1.0 / height.width as f32, 1.0 / height.height as f32);
    let h = |d: Vec2| height.sample_scalar(uv + d) * scale;
    let dhdu = (h(Vec2::new(du, 0.0)) - h(Vec2::new(-du, 0.0))) / (2.0 * du);
    let dhdv = (h(Vec2::new(0.0, dv)) - h(Vec2::new(0.0, -dv))) / (2.0 * dv);
    let n = (dpdu + dhdu * ns).cross(dpdv + dhdv * ns);
    match n.try_normalize() {
        Some(n) if n.dot(ns) < 0.0 => -n,
        Some(n) => n,
        None => ns,
    }
}

/// The normal a tangent-space normal map gives at `uv`, for the interpolated tangent
/// `tangent` (xyz, and the bitangent's sign in w) and unit normal `ns`.
pub fn normal_map(ns: Vec3, tangent: Vec4, map: &Texture, uv: Vec2) -> Vec3 {
    let t = tangent.truncate();
    if t == Vec3::ZERO {
        return ns;
    }
    let sign = if tangent.w < 0.0 { -1.0 } else { 1.0 };
    let b = sign * ns.cross(t);
    let n = map.sample(uv) * 2.0 - Vec3::ONE;
    (n.x * t + n.y * b + n.z * ns).try_normalize().unwrap_or(ns)
}

/// `ns` (a unit shading normal on the side of the unit geometric normal `ng`), bent
/// where needed so that `wo` mirrored about it stays above the geometric surface on
/// `wo`'s side; the result is on `ng`'s side.
pub fn keep_reflection_above(ns: Vec3, ng: Vec3, wo: Vec3) -> Vec3 {
    // Work on wo's side of the surface.
    let side = if wo.dot(ng) < 0.0 { -1.0 } else { 1.0 };
    let (n, g) = (ns * side, ng * side);
    let r = 2.0 * wo.dot(n) * n - wo;
    const LIFT: f32 = 0.01;
    if r.dot(g) >= LIFT && wo.dot(n) > 0.0 {
        return ns;
    }
    // The tangential part of the mirror direction, lifted just above the surface, and
    // the normal that mirrors wo onto it: their half vector.
    let tangential = (r - g * r.dot(g)).try_normalize().unwrap_or_else(|| {
        // wo along the normal: any direction in the plane will do.
        g.any_orthonormal_vector()
    });
    let lifted = (tangential + LIFT * g).normalize();
    match (wo + lifted).try_normalize() {
        Some(h) => h * side,
        None => ng,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uv_derivatives_of_a_scaled_quad() {
        let p = [
            Vec3::ZERO,
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 3.0, 0.0),
        ];
        let uv = [Vec2::ZERO, Vec2::X, Vec2::Y];
        let (dpdu, dpdv) = uv_derivatives(p, uv).unwrap();
        assert_eq!(dpdu, Vec3::new(2.0, 0.0, 0.0));
        assert_eq!(dpdv, Vec3::new(0.0, 3.0, 0.0));
        assert!(uv_derivatives(p, [Vec2::ZERO; 3]).is_none());
    }

    #[test]
    fn bent_normals_reflect_above_the_surface() {
        let ng = Vec3::Z;
        // A normal tilted 80° and a grazing viewer on the other side of the tilt.
        let ns = Vec3::new(80f32.to_radians().sin(), 0.0, 80f32.to_radians().cos());
        for wo in [Vec3::new(-1.0, 0.0, 0.2), Vec3::new(-1.0, 0.0, -0.2)] {
            let wo = wo.normalize();
            let n = keep_reflection_above(ns, ng, wo);
            let side = wo.z.signum();
            let r = 2.0 * wo.dot(n) * n - wo;
            assert!(n.dot(ng) > 0.0 && r.z * side > 0.0, "{n} {r}");
            assert!((n.length() - 1.0).abs() < 1e-5);
        }
        // A normal that already reflects above the surface is left alone.
        let wo = Vec3::new(1.0, 0.0, 1.0).normalize();
        let small = Vec3::new(0.1, 0.0, 1.0).normalize();
        assert_eq!(keep_reflection_above(small, ng, wo), small);
    }
}
