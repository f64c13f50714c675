//! Parts of an emissive triangle, so that photons and shadow rays leave a textured emitter in
//! proportion to its texture: a triangle cut k times at its edges' midpoints has 4^k parts of
//! equal area, each an emitter entry with its own power. A part is a `u32`: k in the low 4
//! bits, then k base-4 digits (from the first cut) choosing a child of the corners (a, b, c)
//! with midpoints ab, bc, ca: 0 (a, ab, ca), 1 (ab, b, bc), 2 (ca, bc, c), 3 (bc, ca, ab).
//! `part_barycentrics` in shaders/scene/scene.wgsl decodes it the same way.

use bevy::math::Vec2;

/// The most cuts: 256 parts a triangle.
pub const MAX_LEVEL: u32 = 4;

/// The parts of a triangle cut `level` times (at most [`MAX_LEVEL`]).
pub fn parts(level: u32) -> impl Iterator<Item = u32> {
    let level = level.min(MAX_LEVEL);
    (0..1u32 << (2 * level)).map(move |digits| level | (digits << 4))
}

/// The corners of `part` as barycentrics (weights of the triangle's second and third
/// vertices), as `triangle_point` in scene.wgsl reads them.
pub fn corners(part: u32) -> [Vec2; 3] {
    let mut p = [Vec2::ZERO, Vec2::X, Vec2::Y];
    for i in 0..(part & 15).min(MAX_LEVEL) {
        let (ab, bc, ca) = (
            (p[0] + p[1]) * 0.5,
            (p[1] + p[2]) * 0.5,
            (p[2] + p[0]) * 0.5,
        );
        p = match (part >> (4 + 2 * i)) & 3 {
            0 => [p[0], ab, ca],
            1 => [ab, p[1], bc],
            2 => [ca, bc, p[2]],
            _ => [bc, ca, ab],
        };
    }
    p
}

/// Parts of all textured emitters together, at most.
pub const MAX_PARTS: usize = 1 << 16;

/// The cuts a triangle covering `texels` texels of its emissive texture gets: until a part
/// covers at most 4 texels (which four samples of it average).
pub fn level_for(texels: f32) -> u32 {
    let mut level = 0;
    let mut left = texels;
    while left > 4.0 && level < MAX_LEVEL {
        left /= 4.0;
        level += 1;
    }
    level
}

/// The most cuts each of `triangles` textured emissive triangles may get so that their parts
/// stay within [`MAX_PARTS`].
pub fn most_cuts(triangles: usize) -> u32 {
    (0..=MAX_LEVEL)
        .rev()
        .find(|&level| triangles << (2 * level) <= MAX_PARTS)
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(p: [Vec2; 3]) -> f32 {
        0.5 * (p[1] - p[0]).perp_dot(p[2] - p[0])
    }

    #[test]
    fn parts_tile_the_triangle_in_equal_areas_of_the_same_winding() {
        for level in 0..=MAX_LEVEL {
            let all: Vec<_> = parts(level).map(corners).collect();
            assert_eq!(all.len(), 1 << (2 * level));
            for p in &all {
                let a = area(*p);
                assert!(
                    (a - 0.5 / all.len() as f32).abs() < 1e-6,
                    "level {level}: {a}"
                );
            }
            // Each part's centroid lies in the triangle, and no two parts share one.
            let mut centroids: Vec<_> = all.iter().map(|p| (p[0] + p[1] + p[2]) / 3.0).collect();
            assert!(
                centroids
                    .iter()
                    .all(|c| c.x > 0.0 && c.y > 0.0 && c.x + c.y < 1.0)
            );
            centroids.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
            assert!(centroids.windows(2).all(|w| w[0].distance(w[1]) > 1e-4));
        }
    }

    #[test]
    fn levels_follow_the_texels_covered() {
        assert_eq!(level_for(0.0), 0);
        assert_eq!(level_for(4.0), 0);
        assert_eq!(level_for(5.0), 1);
        assert_eq!(level_for(1e9), MAX_LEVEL);
        assert_eq!(most_cuts(2), MAX_LEVEL);
        assert_eq!(most_cuts(1 << 12), 2);
        assert_eq!(most_cuts(1 << 20), 0);
    }
}
