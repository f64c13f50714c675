//! The gathers' row ranges (`face_gather` and `gather_row_run` in shaders/photons/map.wgsl),
//! in the same f32 arithmetic, so that a test can show they never leave out a tile that holds
//! a point of the gather kernel. The shaders are the renderer; this mirror is their proof.

use bevy::math::{Mat3, Vec2, Vec3, Vec4};

/// Widening of each row's band and ends, in face coordinates (as in map.wgsl).
pub(crate) const MARGIN: f32 = 1e-4;

/// Share of the ellipsoid's bound spent on the kernel's thickness (`DISC_SHARE` in map.wgsl):
/// semi-axes r / √(1 − w) across and h / √w along the normal hold the cylinder of radius r
/// and half-height h.
pub(crate) const DISC_SHARE: f32 = 0.2;

/// A projection on a cubemap face as the conic a x² + 2h xy + b y² + 2g x + 2f y + k <= 0 of
/// offsets from its centre's projection.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Conic {
    /// (a, h, b) and (g, f, k).
    quadratic: Vec3,
    linear: Vec3,
    /// x offsets of the leftmost and rightmost points, then their y offsets.
    extremes: Vec4,
    /// y offsets of the lowest and highest points.
    heights: Vec2,
}

/// The conic of the ellipsoid (x − p)ᵀ M (x − p) <= 1 seen from the origin, for `u` the unit
/// direction to p, `s2` its in-plane semi-axis over |p|, squared, and `m` = semi-axis² · M;
/// `None` where it is not a bounded ellipse (the ellipsoid holds the origin or reaches the
/// face's horizon).
fn conic(u: Vec3, s2: f32, m: Mat3) -> Option<Conic> {
    let mu = m * u;
    let e = u.dot(mu) - s2;
    if u.z <= 0.0 || e <= 0.0 {
        return None;
    }
    let a = e * m.x_axis.x - mu.x * mu.x;
    let h = e * m.y_axis.x - mu.x * mu.y;
    let b = e * m.y_axis.y - mu.y * mu.y;
    let g = -s2 * mu.x / u.z;
    let f = -s2 * mu.y / u.z;
    let k = -s2 * (e + s2) / (u.z * u.z);
    let qa = a * b - h * h;
    let qb = g * b - h * f;
    let qc = k * b - f * f;
    let disc = qb * qb - qa * qc;
    if a <= 0.0 || b <= 0.0 || qa <= 0.01 * a * b || disc < 0.0 {
        return None;
    }
    let x_lo = (-qb - disc.sqrt()) / qa;
    let x_hi = (-qb + disc.sqrt()) / qa;
    // The points with a horizontal tangent lie on a x + h y + g = 0.
    let qb_y = f * a - h * g;
    let disc_y = (qb_y * qb_y - qa * (k * a - g * g)).max(0.0);
    Some(Conic {
        quadratic: Vec3::new(a, h, b),
        linear: Vec3::new(g, f, k),
        extremes: Vec4::new(x_lo, x_hi, -(h * x_lo + f) / b, -(h * x_hi + f) / b),
        heights: Vec2::new((-qb_y - disc_y.sqrt()) / qa, (-qb_y + disc_y.sqrt()) / qa),
    })
}

/// A gather kernel (the ball of radius `r` around `l`, cut to |n·(x − l)| <= `thickness`)
/// seen on a face: its centre's projection, its sphere's conic and, where it is one, the
/// conic of an ellipsoid holding the cut ball (a thin disc seen at a grazing angle is far
/// narrower than its sphere).
#[derive(Clone, Copy, Debug)]
pub(crate) struct FaceKernel {
    centre: Vec2,
    sphere: Conic,
    disc: Option<Conic>,
}

/// The kernel around `l` (in the face's frame: x, y across, z along the face's axis), or
/// `None` where the walk keeps the box.
pub(crate) fn face_kernel(l: Vec3, r: f32, n: Vec3, thickness: f32) -> Option<FaceKernel> {
    let distance2 = l.dot(l);
    let s2 = r * r / distance2;
    if s2.is_nan() || s2 >= 1.0 {
        return None;
    }
    let u = l / distance2.sqrt();
    let sphere = conic(u, s2, Mat3::IDENTITY)?;
    // Semi-axes² r² / (1 − w) across and h² / w along n, over the first.
    let along = DISC_SHARE * r * r / ((1.0 - DISC_SHARE) * thickness * thickness);
    let nn = Mat3::from_cols(n * n.x, n * n.y, n * n.z);
    let disc = conic(
        u,
        s2 / (1.0 - DISC_SHARE),
        Mat3::IDENTITY + nn * (along - 1.0),
    );
    Some(FaceKernel {
        centre: Vec2::new(u.x / u.z, u.y / u.z),
        sphere,
        disc,
    })
}

impl Conic {
    /// The x offset of the left (`side` -1) or right (1) end at y offset `t`.
    fn end(&self, t: f32, side: f32) -> f32 {
        let half_b = self.quadratic.y * t + self.linear.x;
        let c = (self.quadratic.z * t + 2.0 * self.linear.y) * t + self.linear.z;
        let disc = (half_b * half_b - self.quadratic.x * c).max(0.0);
        (side * disc.sqrt() - half_b) / self.quadratic.x
    }

    /// The x offsets the conic reaches over the band of y offsets [t0, t1].
    fn band(&self, t0: f32, t1: f32) -> (f32, f32) {
        (
            self.end(self.extremes.z.clamp(t0, t1), -1.0),
            self.end(self.extremes.w.clamp(t0, t1), 1.0),
        )
    }
}

impl FaceKernel {
    /// The rows y0..=y1 of a `grid`² face that the kernel reaches (before the box's clamp):
    /// those of the sphere and of the disc's ellipsoid.
    pub(crate) fn rows(&self, grid: u32) -> (i32, i32) {
        let mut heights = self.sphere.heights;
        if let Some(disc) = self.disc {
            heights = Vec2::new(heights.x.max(disc.heights.x), heights.y.min(disc.heights.y));
        }
        let grid = grid as f32;
        let row = |s: f32| ((1.0 - s) * 0.5 * grid).floor() as i32;
        (
            row(self.centre.y + heights.y + MARGIN),
            row(self.centre.y + heights.x - MARGIN),
        )
    }

    /// The tiles x0..=x1 of row `y` of a `grid`² face that the kernel's band reaches
    /// (before the box's clamp): the sphere's range, cut to the disc's.
    pub(crate) fn row_tiles(&self, y: i32, grid: u32) -> (i32, i32) {
        let grid = grid as f32;
        let t0 = 1.0 - 2.0 * (y + 1) as f32 / grid - self.centre.y - MARGIN;
        let t1 = 1.0 - 2.0 * y as f32 / grid - self.centre.y + MARGIN;
        let (mut lo, mut hi) = self.sphere.band(t0, t1);
        if let Some(disc) = self.disc {
            let (disc_lo, disc_hi) = disc.band(t0, t1);
            lo = lo.max(disc_lo);
            hi = hi.min(disc_hi);
        }
        let lo = self.centre.x + lo - MARGIN;
        let hi = self.centre.x + hi + MARGIN;
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

    /// Every point of a kernel (a ball cut to a slab about its plane) seen on the face lies in
    /// a tile of its row's range, for kernels near and far, small and wide, thin and round,
    /// facing any way, at the face's centre and near its edges and horizon, on grids of 64 to
    /// 4 096 tiles.
    #[test]
    fn row_ranges_hold_every_point_of_the_kernel() {
        let mut state = 0x9e37_79b9u32;
        let (mut kernels, mut discs) = (0, 0);
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
            let n = Vec3::new(
                2.0 * next(&mut state) - 1.0,
                2.0 * next(&mut state) - 1.0,
                2.0 * next(&mut state) - 1.0,
            )
            .normalize();
            let thickness = r * 10f32.powf(-2.0 * next(&mut state));
            let Some(kernel) = face_kernel(l, r, n, thickness) else {
                continue;
            };
            kernels += 1;
            discs += kernel.disc.is_some() as u32;
            let across = n.any_orthonormal_vector();
            let across2 = n.cross(across);
            for point in 0..400 {
                // A point of the kernel; every other one on its boundary.
                let edge = point % 2 == 0;
                let along = thickness
                    * if edge && point % 4 == 0 {
                        if next(&mut state) < 0.5 { -1.0 } else { 1.0 }
                    } else {
                        2.0 * next(&mut state) - 1.0
                    };
                let reach = (r * r - along * along).max(0.0).sqrt();
                let rho = reach * if edge { 1.0 } else { next(&mut state).sqrt() };
                let phi = std::f32::consts::TAU * next(&mut state);
                let q = l + n * along + (across * phi.cos() + across2 * phi.sin()) * rho;
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
                let (y0, y1) = kernel.rows(grid);
                assert!(
                    y0 <= y && y <= y1,
                    "row {y} outside {y0}..={y1}: l {l:?} r {r} n {n:?} thickness {thickness}"
                );
                let (x0, x1) = kernel.row_tiles(y, grid);
                assert!(
                    x0 <= x && x <= x1,
                    "tile {x} of row {y} outside {x0}..={x1}: l {l:?} r {r} n {n:?} \
                     thickness {thickness} grid {grid}"
                );
            }
        }
        assert!(
            kernels > 2000 && discs > 1000,
            "{kernels} kernels, {discs} discs"
        );
    }

    /// A round kernel straight ahead projects to a circle of radius tan(asin(r/d)): each
    /// row's range is its chord at the band's edge nearest the centre, to the tile.
    #[test]
    fn a_round_kernel_ahead_has_the_rows_of_a_circle() {
        let grid = 256;
        let kernel = face_kernel(Vec3::Z, 0.1, Vec3::Z, 0.1).unwrap();
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
                kernel.row_tiles(y, grid),
                (tile(-half), tile(half)),
                "row {y}"
            );
        }
        // The circle's top row is a few tiles of its 26.
        let (x0, x1) = kernel.row_tiles(115, grid);
        assert!(x1 - x0 < 10, "{x0}..={x1}");
    }

    /// A thin kernel seen edge on (a floor at the eye's height) reaches few of its sphere's
    /// rows.
    #[test]
    fn a_kernel_seen_edge_on_reaches_few_rows() {
        let grid = 256;
        let kernel = face_kernel(Vec3::Z, 0.1, Vec3::Y, 0.01).unwrap();
        let (y0, y1) = kernel.rows(grid);
        let rows = y1 - y0 + 1;
        // The sphere reaches 26 rows; the slab's ±0.01 is under 2 rows each side.
        assert!((2..=6).contains(&rows), "{rows} rows");
    }
}
