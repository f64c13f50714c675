//! The gathers' row ranges (`face_gather` and `gather_row_run` in shaders/photons/map.wgsl),
//! in the same f32 arithmetic, so that a test can show they never leave out a tile that holds
//! a point of the gather sphere. The shaders are the renderer; this mirror is their proof.

use bevy::math::{Vec2, Vec3, Vec4};

/// Widening of each row's band and ends, in face coordinates (as in map.wgsl).
const MARGIN: f32 = 1e-4;

/// A gather sphere's projection on a cubemap face as the conic
/// a x² + 2h xy + b y² + 2g x + 2f y + k <= 0 of offsets from its centre's projection.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FaceEllipse {
    centre: Vec2,
    /// (a, h, b) and (g, f, k).
    quadratic: Vec3,
    linear: Vec3,
    /// x offsets of the leftmost and rightmost points, then their y offsets.
    extremes: Vec4,
}

/// The ellipse of a sphere of radius `r` around `l` (in the face's frame: x, y across, z
/// along the face's axis), or `None` where the walk keeps the box (the sphere holds the
/// cubemap's centre or reaches the face's horizon).
pub(crate) fn face_ellipse(l: Vec3, r: f32) -> Option<FaceEllipse> {
    let distance2 = l.dot(l);
    let s2 = r * r / distance2;
    if s2.is_nan() || s2 >= 1.0 {
        return None;
    }
    let u = l / distance2.sqrt();
    if u.z <= 0.0 || u.z * u.z <= s2 * 1.01 {
        return None;
    }
    let c2 = 1.0 - s2;
    let (a, h, b) = (c2 - u.x * u.x, -u.x * u.y, c2 - u.y * u.y);
    let (g, f, k) = (-s2 * u.x / u.z, -s2 * u.y / u.z, -s2 / (u.z * u.z));
    let qa = a * b - h * h;
    let qb = g * b - h * f;
    let qc = k * b - f * f;
    let disc = qb * qb - qa * qc;
    if qa <= 0.0 || b <= 0.0 || a <= 0.0 || disc < 0.0 {
        return None;
    }
    let x_lo = (-qb - disc.sqrt()) / qa;
    let x_hi = (-qb + disc.sqrt()) / qa;
    Some(FaceEllipse {
        centre: Vec2::new(u.x / u.z, u.y / u.z),
        quadratic: Vec3::new(a, h, b),
        linear: Vec3::new(g, f, k),
        extremes: Vec4::new(x_lo, x_hi, -(h * x_lo + f) / b, -(h * x_hi + f) / b),
    })
}

impl FaceEllipse {
    /// The x offset of the left (`side` -1) or right (1) end at y offset `t`.
    fn end(&self, t: f32, side: f32) -> f32 {
        let half_b = self.quadratic.y * t + self.linear.x;
        let c = (self.quadratic.z * t + 2.0 * self.linear.y) * t + self.linear.z;
        let disc = (half_b * half_b - self.quadratic.x * c).max(0.0);
        (side * disc.sqrt() - half_b) / self.quadratic.x
    }

    /// The tiles x0..=x1 of row `y` of a `grid`² face that the ellipse's band reaches
    /// (before the box's clamp).
    pub(crate) fn row_tiles(&self, y: i32, grid: u32) -> (i32, i32) {
        let grid = grid as f32;
        let t0 = 1.0 - 2.0 * (y + 1) as f32 / grid - self.centre.y - MARGIN;
        let t1 = 1.0 - 2.0 * y as f32 / grid - self.centre.y + MARGIN;
        let lo = self.centre.x + self.end(self.extremes.z.clamp(t0, t1), -1.0) - MARGIN;
        let hi = self.centre.x + self.end(self.extremes.w.clamp(t0, t1), 1.0) + MARGIN;
        (
            ((lo + 1.0) * 0.5 * grid).floor() as i32,
            ((hi + 1.0) * 0.5 * grid).floor() as i32,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// xorshift: the test's points, the same on every run.
    fn next(state: &mut u32) -> f32 {
        *state ^= *state << 13;
        *state ^= *state >> 17;
        *state ^= *state << 5;
        (*state >> 8) as f32 / (1u32 << 24) as f32
    }

    /// Every point of a sphere seen on the face lies in a tile of its row's range, for
    /// spheres near and far, small and wide, at the face's centre and near its edges and
    /// horizon, on grids of 64 to 4096 tiles.
    #[test]
    fn row_ranges_hold_every_point_of_the_sphere() {
        let mut state = 0x9e37_79b9u32;
        let mut ellipses = 0;
        for case in 0..4000 {
            let grid = [64u32, 256, 1024, 4096][case % 4];
            let distance = 0.01 * 10f32.powf(6.0 * next(&mut state));
            // Directions over the whole face and a little beyond its edges.
            let dir = Vec3::new(
                2.4 * next(&mut state) - 1.2,
                2.4 * next(&mut state) - 1.2,
                1.0,
            )
            .normalize();
            let l = dir * distance;
            let r = distance * 10f32.powf(-4.0 * next(&mut state)) * 0.9;
            let Some(ellipse) = face_ellipse(l, r) else {
                continue;
            };
            ellipses += 1;
            for _ in 0..400 {
                // A point of the ball, its surface included.
                let v = Vec3::new(
                    2.0 * next(&mut state) - 1.0,
                    2.0 * next(&mut state) - 1.0,
                    2.0 * next(&mut state) - 1.0,
                );
                let v = if v.length() > 1.0 { v.normalize() } else { v };
                let q = l + v * r;
                if q.z <= 0.0 {
                    continue;
                }
                let s = Vec2::new(q.x / q.z, q.y / q.z);
                if s.x.abs() > 1.0 || s.y.abs() > 1.0 {
                    continue;
                }
                // The tile as cubemap_tile (common.wgsl) finds it.
                let g = grid as f32;
                let cell = Vec2::new((s.x + 1.0) * 0.5 * g, (1.0 - s.y) * 0.5 * g)
                    .clamp(Vec2::ZERO, Vec2::splat(g - 1.0));
                let (x, y) = (cell.x as i32, cell.y as i32);
                let (x0, x1) = ellipse.row_tiles(y, grid);
                assert!(
                    x0 <= x && x <= x1,
                    "tile {x} of row {y} outside {x0}..={x1}: l {l:?} r {r} grid {grid}"
                );
            }
        }
        assert!(ellipses > 2000, "{ellipses} ellipses");
    }

    /// A sphere straight ahead projects to a circle of radius tan(asin(r/d)): each row's
    /// range is its chord at the band's edge nearest the centre, to the tile.
    #[test]
    fn a_sphere_ahead_has_the_rows_of_a_circle() {
        let grid = 256;
        let ellipse = face_ellipse(Vec3::new(0.0, 0.0, 1.0), 0.1).unwrap();
        let radius = 0.1f32.asin().tan();
        let tile = |s: f32| ((s + 1.0) * 0.5 * grid as f32).floor() as i32;
        for y in 0..grid as i32 {
            let top = 1.0 - 2.0 * y as f32 / grid as f32;
            let nearest = 0f32.clamp(top - 2.0 / grid as f32, top);
            if nearest.abs() > radius {
                continue;
            }
            let half = (radius * radius - nearest * nearest).sqrt();
            assert_eq!(
                ellipse.row_tiles(y, grid),
                (tile(-half), tile(half)),
                "row {y}"
            );
        }
        // The circle's top row is a few tiles of its 26.
        let (x0, x1) = ellipse.row_tiles(115, grid);
        assert!(x1 - x0 < 10, "{x0}..={x1}");
    }
}
