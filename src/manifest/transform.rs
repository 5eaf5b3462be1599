//! LocalToWorld: the `<TransformGroup>` operations composed in document order.
//!
//! `M = Op1 · Op2 · … · Opn`, like a scene graph or an OpenGL matrix stack: the operation listed
//! last is applied to points first. For the thesis example
//! `p_world = T(0,0,1.15) · Rz(90°) · S(−1,1,1) · p_local`.

use glam::{DMat4, DVec3};

use super::Transform;

impl Transform {
    /// The operation's 4×4 matrix. Rotations are right-handed (counter-clockwise when looking
    /// down the axis towards the origin) about the normalised axis; a zero or non-finite axis,
    /// refused by the parser, gives the identity so that this stays a total function.
    pub fn matrix(&self) -> DMat4 {
        match *self {
            Transform::Translate(v) => DMat4::from_translation(DVec3::from(v)),
            Transform::Rotate { axis, angle_deg } => {
                // Scaled by its largest component first, so that `1e200 1e200 1e200` is a direction
                // (its squared length would overflow).
                let v = DVec3::from(axis);
                let axis = (v / v.abs().max_element()).try_normalize();
                match axis {
                    Some(a) => DMat4::from_axis_angle(a, angle_deg.to_radians()),
                    None => DMat4::IDENTITY,
                }
            }
            Transform::Scale(v) => DMat4::from_scale(DVec3::from(v)),
        }
    }
}

/// Whether a LocalToWorld can be used on points: finite entries within ±1e150 (so moving a point
/// cannot overflow) and invertible.
pub fn is_usable(m: &DMat4) -> bool {
    let det = m.determinant();
    m.to_cols_array().iter().all(|x| x.abs() <= 1e150)
        && det.is_finite()
        && det != 0.0
        && m.inverse().is_finite()
}

/// The panorama centre (the local origin) in the world: the default eye.
pub fn centre(local_to_world: DMat4) -> DVec3 {
    local_to_world.transform_point3(DVec3::ZERO)
}

/// Compose in document order (see the module documentation).
pub fn compose(ops: &[Transform]) -> DMat4 {
    ops.iter().fold(DMat4::IDENTITY, |m, op| m * op.matrix())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: DVec3, b: DVec3) -> bool {
        (a - b).length() < 1e-12
    }

    #[test]
    fn rotation_is_right_handed_in_degrees() {
        let r = Transform::Rotate { axis: [0.0, 0.0, 2.0], angle_deg: 90.0 }.matrix();
        assert!(close(r.transform_point3(DVec3::X), DVec3::Y));
        let r = Transform::Rotate { axis: [1.0, 0.0, 0.0], angle_deg: 90.0 }.matrix();
        assert!(close(r.transform_point3(DVec3::Y), DVec3::Z));
    }

    #[test]
    fn last_listed_is_applied_first() {
        let t = Transform::Translate([1.0, 0.0, 0.0]);
        let s = Transform::Scale([2.0, 2.0, 2.0]);
        // T · S · (1,0,0) = T(2,0,0) = (3,0,0); S · T · (1,0,0) = S(2,0,0) = (4,0,0).
        assert!(close(compose(&[t, s]).transform_point3(DVec3::X), DVec3::new(3.0, 0.0, 0.0)));
        assert!(close(compose(&[s, t]).transform_point3(DVec3::X), DVec3::new(4.0, 0.0, 0.0)));
    }

    #[test]
    fn huge_and_tiny_axes_are_directions() {
        for s in [1e200, 1e-200, 1.0] {
            let r = Transform::Rotate { axis: [0.0, 0.0, s], angle_deg: 90.0 }.matrix();
            assert!(close(r.transform_point3(DVec3::X), DVec3::Y), "axis scale {s}");
        }
        let r = Transform::Rotate { axis: [1e200; 3], angle_deg: 120.0 }.matrix();
        assert!(close(r.transform_point3(DVec3::X), DVec3::Y), "the (1,1,1) axis cycles the axes");
    }

    #[test]
    fn overflowing_or_singular_transforms_are_not_usable() {
        let t = |v| Transform::Translate(v);
        assert!(is_usable(&compose(&[t([1.0, 2.0, 3.0]), Transform::Scale([-1.0, 1.0, 1.0])])));
        assert!(!is_usable(&compose(&[t([1e308, 0.0, 0.0])])), "moving a point would overflow");
        assert!(!is_usable(&compose(&[Transform::Scale([1e300; 3]); 3])), "the product overflows");
        assert!(!is_usable(&compose(&[Transform::Scale([1e-300; 3]); 2])), "the determinant underflows");
    }

    #[test]
    fn zero_axis_is_identity() {
        let r = Transform::Rotate { axis: [0.0; 3], angle_deg: 30.0 }.matrix();
        assert_eq!(r, DMat4::IDENTITY);
    }
}
