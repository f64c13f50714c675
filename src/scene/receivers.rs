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

/// The plane through the `triangles` of one emissive instance (a quad, a panel) when all
/// their corners lie on it within a hundred-thousandth of its first triangle's size (and
/// their coordinates' rounding): its point and unit normal. None for a curved or broken one;
/// stops at the first corner off the plane.
pub fn common_plane<I>(triangles: I) -> Option<(Vec3, Vec3, f32)>
where
    I: Iterator<Item = [Vec3; 3]> + Clone,
{
    let [a, b, c] = triangles
        .clone()
        .find(|[a, b, c]| (b - a).cross(c - a) != Vec3::ZERO)?;
    let normal = (b - a).cross(c - a).try_normalize()?;
    let size = (b - a).length().max((c - a).length());
    let eps = 1e-5 * size + 1e-6 * a.abs().max_element();
    let mut corners = triangles.flatten();
    let flat = corners.all(|p| (p - a).dot(normal).abs() <= eps);
    flat.then_some((a, normal, eps))
}

/// The bounding sphere of the `boxes` (world min, max), but box `own`, that reach more than
/// `eps` in front of the plane through `point` with unit `normal`: photons leaving that side
/// meet nothing else (a box wholly behind or on the plane cannot be met). Its radius has a
/// margin of 10⁻⁴ for the GPU's rounding of the same corners. Radius 0 when none is in front.
pub fn front_sphere(
    point: Vec3,
    normal: Vec3,
    boxes: &[(Vec3, Vec3)],
    own: usize,
    eps: f32,
) -> [f32; 4] {
    let mut union: Option<(Vec3, Vec3)> = None;
    for (i, &(lo, hi)) in boxes.iter().enumerate() {
        // The corner farthest along the normal.
        let far = Vec3::select(normal.cmpge(Vec3::ZERO), hi, lo);
        if i != own && (far - point).dot(normal) > eps {
            union = Some(union.map_or((lo, hi), |(a, b)| (a.min(lo), b.max(hi))));
        }
    }
    match union {
        Some((lo, hi)) => {
            let centre = 0.5 * (lo + hi);
            let radius = 0.5 * (hi - lo).length() * (1.0 + 1e-4) + eps;
            [centre.x, centre.y, centre.z, radius]
        }
        None => [0.0; 4],
    }
}

/// A flat emissive instance's plane and both sides' receivers among the instances' `boxes`
/// but its own (`own`: all of it lies on the plane, though a tilted quad's box does not),
/// or None when the instance is not flat (its photons then leave over the hemisphere).
pub fn emitter_plane<I>(triangles: I, boxes: &[(Vec3, Vec3)], own: usize) -> Option<EmitterPlane>
where
    I: Iterator<Item = [Vec3; 3]> + Clone,
{
    let (point, normal, eps) = common_plane(triangles)?;
    Some(EmitterPlane {
        normal,
        front: front_sphere(point, normal, boxes, own, eps),
        back: front_sphere(point, -normal, boxes, own, eps),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::math::Quat;

    fn quad(y: f32, half: f32) -> Vec<[Vec3; 3]> {
        let [a, b, c, d] = [
            Vec3::new(-half, y, -half),
            Vec3::new(half, y, -half),
            Vec3::new(half, y, half),
            Vec3::new(-half, y, half),
        ];
        vec![[a, b, c], [a, c, d]]
    }

    fn moved(triangles: &[[Vec3; 3]], f: impl Fn(Vec3) -> Vec3) -> Vec<[Vec3; 3]> {
        triangles.iter().map(|t| t.map(&f)).collect()
    }

    #[test]
    fn a_sky_panel_faces_the_pool_below_it_and_nothing_above() {
        let boxes = [
            (Vec3::new(-4.0, 3.0, -4.0), Vec3::new(4.0, 3.0, 4.0)),
            (Vec3::new(-1.5, -0.8, -1.5), Vec3::new(1.5, 0.1, 1.5)),
        ];
        let plane = emitter_plane(quad(3.0, 4.0).into_iter(), &boxes, 0).unwrap();
        let down = plane.toward(Vec3::NEG_Y);
        assert!((Vec3::from_slice(&down[..3]) - Vec3::new(0.0, -0.35, 0.0)).length() < 1e-6);
        let half_diagonal = (Vec3::new(3.0, 0.9, 3.0) * 0.5).length();
        assert!(down[3] >= half_diagonal && down[3] < half_diagonal * 1.001);
        assert_eq!(plane.toward(Vec3::Y), [0.0; 4]);
    }

    #[test]
    fn a_tilted_panel_is_no_receiver_of_its_own() {
        let tilt = Quat::from_rotation_x(0.35);
        let panel = moved(&quad(0.0, 2.0), |p| tilt * p + Vec3::Y * 2.5);
        let corners = panel.iter().flatten();
        let (lo, hi) = corners.fold((Vec3::MAX, Vec3::MIN), |(a, b), &p| (a.min(p), b.max(p)));
        let set = (Vec3::new(-1.0, 0.0, -0.8), Vec3::new(1.0, 1.2, 0.8));
        let plane = emitter_plane(panel.into_iter(), &[(lo, hi), set], 0).unwrap();
        let down = plane.toward(tilt * Vec3::NEG_Y);
        let radius = 0.5 * (set.1 - set.0).length();
        assert!(down[3] >= radius && down[3] < radius * 1.001);
        assert_eq!(plane.toward(tilt * Vec3::Y), [0.0; 4]);
    }

    #[test]
    fn a_box_straddling_the_plane_is_a_receiver() {
        let boxes = [(Vec3::new(-1.0, -1.0, -1.0), Vec3::new(1.0, 1.0, 1.0))];
        let up = front_sphere(Vec3::ZERO, Vec3::Y, &boxes, usize::MAX, 1e-5);
        let down = front_sphere(Vec3::ZERO, Vec3::NEG_Y, &boxes, usize::MAX, 1e-5);
        assert_eq!(up, down);
        assert!(up[3] >= 3f32.sqrt() && up[3] < 3f32.sqrt() * 1.001);
    }

    #[test]
    fn curved_or_empty_emitters_have_no_plane() {
        let mut bent = quad(0.0, 1.0);
        bent[1][2].y = 0.1;
        assert!(common_plane(bent.into_iter()).is_none());
        assert!(common_plane(std::iter::empty()).is_none());
        let line = [[Vec3::ZERO, Vec3::X, Vec3::X * 2.0]];
        assert!(common_plane(line.into_iter()).is_none());
        // Far from the origin and tilted, a flat quad is still flat.
        let tilt = Quat::from_rotation_x(0.7);
        let far = moved(&quad(0.0, 1.0), |p| tilt * p + Vec3::splat(1000.0));
        let (_, n, _) = common_plane(far.into_iter()).unwrap();
        assert!((n.dot(tilt * Vec3::Y).abs() - 1.0).abs() < 1e-5);
    }
}
