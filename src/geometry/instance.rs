//! A mesh placed in the world: the unit of two-level acceleration structures, where one
//! copy of each distinct mesh is placed many times under affine transforms.
//!
//! A ray meets an instance in the mesh's own (object) space: its origin and direction
//! go through the inverse transform, and the direction is *not* normalised, so the
//! parameter `t` of a point on the ray is the same in both spaces and a hit's `t` needs
//! no conversion back to the world.

use glam::{Affine3A, Vec3, Vec3A};

use super::Ray;

/// Mesh `mesh` (an index into the structure's list of distinct meshes) placed by
/// `transform`, which takes its object space to the world.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instance {
    pub mesh: u32,
    pub transform: Affine3A,
}

/// Why a list of instances cannot be placed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum InstanceError {
    #[error("instance {instance} names mesh {mesh}, but there are {meshes} meshes")]
    UnknownMesh {
        instance: usize,
        mesh: u32,
        meshes: usize,
    },
    #[error("instance {instance} has a transform that is not finite or not invertible")]
    Singular { instance: usize },
}

/// The largest coordinate a ray may have where a backend takes it, in the world or in
/// an instance's object space: Embree's `FLT_LARGE`, past which Embree refuses a ray
/// (and, built with assertions as Debian's 3.13.5 is, aborts the process).
pub const MAX_RAY_COORDINATE: f32 = 1.844e18;

/// How far from the scene rays must be carried whole by every placement: from any
/// point whose coordinates are within this many times the placed scene's own (a
/// camera may stand far off).
pub const RAY_REACH: f32 = 1024.0;

impl Instance {
    /// Why a ray in the world cannot be taken to this instance's object space in
    /// `f32` and within [`MAX_RAY_COORDINATE`]: a unit direction, or an origin whose
    /// coordinates are at most `reach`, would come out larger (an axis scaled far
    /// down). `None` when every such ray is carried.
    pub fn carry_error(&self, reach: f32) -> Option<String> {
        let Some(inverse) = self.to_object() else {
            return Some(format!(
                "it cannot be inverted in f32 (its determinant is {:e})",
                self.transform.matrix3.determinant()
            ));
        };
        let stretch = max_row_sum(&inverse);
        let largest = stretch * reach.max(1.0) + inverse.translation.abs().max_element();
        // NaN is not carried either.
        let carried = largest < MAX_RAY_COORDINATE;
        (!carried).then(|| {
            format!(
                "in the OBJ's own space it stretches lengths by up to {stretch:.3e}: a ray \
                 from within {reach:.3e} of the origin would reach {largest:.3e}, past the \
                 {MAX_RAY_COORDINATE:.3e} that f32 rays in Embree can carry"
            )
        })
    }

    /// The largest ray coordinates, origin and direction, that this instance carries to
    /// its object space within [`MAX_RAY_COORDINATE`] (see [`Instance::carry_error`]).
    pub fn carried(&self) -> (f32, f32) {
        let Some(inverse) = self.to_object() else {
            return (0.0, 0.0);
        };
        let stretch = max_row_sum(&inverse).max(f32::MIN_POSITIVE);
        let origin = (MAX_RAY_COORDINATE - inverse.translation.abs().max_element()) / stretch;
        (origin.max(0.0), MAX_RAY_COORDINATE / stretch)
    }

    /// The transform from the world to object space, or `None` when the transform has
    /// a non-finite entry or no finite inverse (a zero scale, a flattening matrix).
    pub fn to_object(&self) -> Option<Affine3A> {
        let t = &self.transform;
        if !t.is_finite() || t.matrix3.determinant() == 0.0 {
            return None;
        }
        let inverse = t.inverse();
        inverse.is_finite().then_some(inverse)
    }

    /// The world-space box around this instance of a mesh whose object-space box is
    /// `[lo, hi]`: the box of its eight transformed corners, widened by a relative
    /// 2⁻¹⁸ so that the rounding of the transform cannot leave a surface point out.
    pub fn world_bounds(&self, [lo, hi]: [Vec3; 2]) -> [Vec3A; 2] {
        let mut world = [Vec3A::INFINITY, Vec3A::NEG_INFINITY];
        for corner in 0..8 {
            let pick = |axis: usize, l: f32, h: f32| if corner >> axis & 1 == 0 { l } else { h };
            let p = Vec3A::new(
                pick(0, lo.x, hi.x),
                pick(1, lo.y, hi.y),
                pick(2, lo.z, hi.z),
            );
            let q = self.transform.transform_point3a(p);
            world = [world[0].min(q), world[1].max(q)];
        }
        let scale = (world[1] - world[0]).max(world[0].abs().max(world[1].abs()));
        let pad = scale * (1.0 / (1 << 18) as f32);
        [world[0] - pad, world[1] + pad]
    }
}

/// The largest factor by which `t`'s linear part lengthens a coordinate: its largest
/// row sum of absolute values (the infinity norm).
fn max_row_sum(t: &Affine3A) -> f32 {
    let m = t.matrix3;
    let rows = m.x_axis.abs() + m.y_axis.abs() + m.z_axis.abs();
    rows.max_element()
}

/// The inverse transforms of `instances`, after checking that each names one of
/// `meshes` meshes and can be inverted.
pub fn object_transforms(
    instances: &[Instance],
    meshes: usize,
) -> Result<Vec<Affine3A>, InstanceError> {
    instances
        .iter()
        .enumerate()
        .map(|(i, instance)| {
            if instance.mesh as usize >= meshes {
                return Err(InstanceError::UnknownMesh {
                    instance: i,
                    mesh: instance.mesh,
                    meshes,
                });
            }
            instance
                .to_object()
                .ok_or(InstanceError::Singular { instance: i })
        })
        .collect()
}

/// `ray` in the object space that `to_object` takes the world to, with the same `t`
/// range: the direction keeps the length the transform gives it.
#[inline]
pub fn object_ray(to_object: &Affine3A, ray: &Ray, tmax: f32) -> Ray {
    Ray {
        origin: to_object.transform_point3(ray.origin),
        dir: to_object.transform_vector3(ray.dir),
        tmin: ray.tmin,
        tmax,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Quat;

    #[test]
    fn an_object_ray_meets_the_transformed_point_at_the_same_t() {
        let instance = Instance {
            mesh: 0,
            transform: Affine3A::from_scale_rotation_translation(
                Vec3::new(-2.0, 0.5, 3.0),
                Quat::from_axis_angle(Vec3::new(1.0, -1.0, 2.0).normalize(), 0.7),
                Vec3::new(1.0, 2.0, -3.0),
            ),
        };
        let to_object = instance.to_object().unwrap();
        let ray = Ray::new(Vec3::new(0.3, -4.0, 2.0), Vec3::new(0.2, 1.0, -0.1));
        let local = object_ray(&to_object, &ray, ray.tmax);
        for t in [0.0f32, 0.5, 3.0, 10.0] {
            let back = instance.transform.transform_point3(local.at(t));
            assert!((back - ray.at(t)).length() < 1e-5 * (1.0 + t), "t = {t}");
        }
    }

    #[test]
    fn singular_and_unknown_placements_are_refused() {
        let flat = Instance {
            mesh: 0,
            transform: Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0)),
        };
        let nan = Instance {
            mesh: 0,
            transform: Affine3A::from_translation(Vec3::new(f32::NAN, 0.0, 0.0)),
        };
        let unknown = Instance {
            mesh: 2,
            transform: Affine3A::IDENTITY,
        };
        assert_eq!(
            object_transforms(&[flat], 1),
            Err(InstanceError::Singular { instance: 0 })
        );
        assert_eq!(
            object_transforms(&[unknown, nan], 3),
            Err(InstanceError::Singular { instance: 1 })
        );
        assert!(matches!(
            object_transforms(&[unknown], 2),
            Err(InstanceError::UnknownMesh { mesh: 2, .. })
        ));
    }

    #[test]
    fn world_bounds_hold_every_transformed_corner() {
        let instance = Instance {
            mesh: 0,
            transform: Affine3A::from_rotation_z(0.3) * Affine3A::from_scale(Vec3::splat(-2.0)),
        };
        let (lo, hi) = (Vec3::new(-1.0, 0.0, 2.0), Vec3::new(1.0, 3.0, 2.5));
        let [wlo, whi] = instance.world_bounds([lo, hi]);
        for i in 0..=10 {
            let p = lo.lerp(hi, i as f32 / 10.0);
            let q = Vec3A::from(instance.transform.transform_point3(p));
            assert!(q.cmpge(wlo).all() && q.cmple(whi).all());
        }
    }
}
