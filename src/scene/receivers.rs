//! Where a flat emitter's photons can land: the bounding sphere of the scene's instances in
//! front of its plane. Photons leave toward that sphere (photons/trace.wgsl's `emit`) instead
//! of over the whole hemisphere: a sky panel wider than the pool under it sent 9 photons in 10
//! past everything, and tracing those misses took about half the photon stage.

use bevy::math::Vec3;

/// A flat emissive instance's plane, each side's receivers as a sphere (centre, radius;
/// radius 0: none known, photons leave over the hemisphere).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmitterPlane {
    pub normal: Vec3,
    pub front: [f32; 4],
    pub back: [f32; 4],
}

impl EmitterPlane {
    /// The sphere on the side a triangle of `normal` (its winding's) emits to.
    pub fn toward(&self, normal: Vec3) -> [f32; 4] {
        if normal.dot(self.normal) >= 0.0 {
            self.front
        } else {
            self.back
        }
    }
}

/// The plane through `points` when all lie on it within `eps`: for the triangles of one
/// emissive instance (a quad, a panel). None for a curved or broken one.
pub fn common_plane(points: &[Vec3], eps: f32) -> Option<(Vec3, Vec3)> {
    let (&a, rest) = points.split_first()?;
    // The widest triangle from `a` gives the best-conditioned normal.
    let mut normal = Vec3::ZERO;
    for pair in rest.windows(2) {
        let n = (pair[0] - a).cross(pair[1] - a);
        if n.length_squared() > normal.length_squared() {
            normal = n;
        }
    }
    let normal = normal.try_normalize()?;
    let flat = points.iter().all(|&p| (p - a).dot(normal).abs() <= eps);
    flat.then_some((a, normal))
}

/// The bounding sphere of the `boxes` (world min, max) that reach more than `eps` in front of
/// the plane through `point` with unit `normal`: photons leaving that side meet nothing
/// else (a box wholly behind or on the plane, as the emitter's own quad, cannot be met).
/// Radius 0 when no box is in front.
pub fn front_sphere(point: Vec3, normal: Vec3, boxes: &[(Vec3, Vec3)], eps: f32) -> [f32; 4] {
    let mut union: Option<(Vec3, Vec3)> = None;
    for &(lo, hi) in boxes {
        // The corner farthest along the normal.
        let far = Vec3::select(normal.cmpge(Vec3::ZERO), hi, lo);
        if (far - point).dot(normal) > eps {
            union = Some(union.map_or((lo, hi), |(a, b)| (a.min(lo), b.max(hi))));
        }
    }
    match union {
        Some((lo, hi)) => {
            let centre = 0.5 * (lo + hi);
            let radius = 0.5 * (hi - lo).length();
            [centre.x, centre.y, centre.z, radius]
        }
        None => [0.0; 4],
    }
}

/// A flat emissive instance's plane and both sides' receivers among the instances' `boxes`
/// but its own (`own`: all of it lies on the plane, though a tilted quad's box does not),
/// or None when the instance is not flat (its photons then leave over the hemisphere).
pub fn emitter_plane(
    points: &[Vec3],
    boxes: &[(Vec3, Vec3)],
    own: usize,
    eps: f32,
) -> Option<EmitterPlane> {
    let (point, normal) = common_plane(points, eps)?;
    let others: Vec<_> = (boxes.iter().enumerate())
        .filter_map(|(i, b)| (i != own).then_some(*b))
        .collect();
    Some(EmitterPlane {
        normal,
        front: front_sphere(point, normal, &others, eps),
        back: front_sphere(point, -normal, &others, eps),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(y: f32, half: f32) -> Vec<Vec3> {
        vec![
            Vec3::new(-half, y, -half),
            Vec3::new(half, y, -half),
            Vec3::new(half, y, half),
            Vec3::new(-half, y, half),
        ]
    }

    #[test]
    fn a_sky_panel_faces_the_pool_below_it_and_nothing_above() {
        let boxes = [
            (Vec3::new(-4.0, 3.0, -4.0), Vec3::new(4.0, 3.0, 4.0)),
            (Vec3::new(-1.5, -0.8, -1.5), Vec3::new(1.5, 0.1, 1.5)),
        ];
        let plane = emitter_plane(&quad(3.0, 4.0), &boxes, 0, 1e-5).unwrap();
        let down = plane.toward(Vec3::NEG_Y);
        assert!((Vec3::from_slice(&down[..3]) - Vec3::new(0.0, -0.35, 0.0)).length() < 1e-6);
        let half_diagonal = (Vec3::new(3.0, 0.9, 3.0) * 0.5).length();
        assert!((down[3] - half_diagonal).abs() < 1e-6);
        assert_eq!(plane.toward(Vec3::Y), [0.0; 4]);
    }

    #[test]
    fn a_tilted_panel_is_no_receiver_of_its_own() {
        let tilt = bevy::math::Quat::from_rotation_x(0.35);
        let panel: Vec<Vec3> = quad(0.0, 2.0)
            .iter()
            .map(|&p| tilt * p + Vec3::Y * 2.5)
            .collect();
        let (lo, hi) =
            (panel.iter()).fold((Vec3::MAX, Vec3::MIN), |(a, b), &p| (a.min(p), b.max(p)));
        let set = (Vec3::new(-1.0, 0.0, -0.8), Vec3::new(1.0, 1.2, 0.8));
        let plane = emitter_plane(&panel, &[(lo, hi), set], 0, 1e-5).unwrap();
        let down = plane.toward(tilt * Vec3::NEG_Y);
        assert_eq!(down[3], 0.5 * (set.1 - set.0).length());
        assert_eq!(plane.toward(tilt * Vec3::Y), [0.0; 4]);
    }

    #[test]
    fn a_box_straddling_the_plane_is_a_receiver() {
        let boxes = [(Vec3::new(-1.0, -1.0, -1.0), Vec3::new(1.0, 1.0, 1.0))];
        let up = front_sphere(Vec3::ZERO, Vec3::Y, &boxes, 1e-5);
        let down = front_sphere(Vec3::ZERO, Vec3::NEG_Y, &boxes, 1e-5);
        assert_eq!(up, down);
        assert!((up[3] - 3f32.sqrt()).abs() < 1e-6);
    }

    #[test]
    fn curved_or_empty_emitters_have_no_plane() {
        let mut bent = quad(0.0, 1.0);
        bent[2].y = 0.1;
        assert!(common_plane(&bent, 1e-5).is_none());
        assert!(common_plane(&[], 1e-5).is_none());
        assert!(common_plane(&[Vec3::ZERO, Vec3::X, Vec3::X * 2.0], 1e-5).is_none());
        let tilted: Vec<Vec3> = quad(0.0, 1.0)
            .iter()
            .map(|&p| bevy::math::Quat::from_rotation_x(0.7) * p + Vec3::ONE)
            .collect();
        let (_, n) = common_plane(&tilted, 1e-5).unwrap();
        assert!(
            (n.dot(bevy::math::Quat::from_rotation_x(0.7) * Vec3::Y)
                .abs()
                - 1.0)
                .abs()
                < 1e-5
        );
    }
}
