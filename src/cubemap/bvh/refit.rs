//! A hierarchy kept over moving triangles: the boxes of the leaves that hold moved triangles,
//! and of their ancestors, are made again (no split redone), so a moved object costs its
//! triangles and their paths to the root, on the CPU and in bytes sent. A box that grew much
//! past its built size asks for a build instead (the walk would slow down). Pure maths.

use std::collections::BTreeSet;

use bevy::math::Vec3;

use super::build::{Bounds, Bvh, INNER};

/// A refitted box may grow to this many times its built half area before a build is asked for.
const GROWTH: f32 = 4.0;
/// `leaf_of` a triangle the build left out (not finite).
const NONE: u32 = u32::MAX;

/// A built hierarchy, the world-space triangles its boxes bound, and what refitting needs.
#[derive(Clone, Debug, Default)]
pub struct Refittable {
    pub bvh: Bvh,
    triangles: Vec<[Vec3; 3]>,
    leaf_of: Vec<u32>,
    parent: Vec<u32>,
    built_area: Vec<f32>,
    /// Whether a refit changed it since it was built.
    pub refitted: bool,
}

impl Refittable {
    pub fn build(triangles: Vec<[Vec3; 3]>) -> Self {
        let bvh = Bvh::build(&triangles);
        let mut leaf_of = vec![NONE; triangles.len()];
        let mut parent = vec![NONE; bvh.nodes.len()];
        for (k, n) in bvh.nodes.iter().enumerate() {
            if n.count == INNER {
                parent[n.first as usize] = k as u32;
                parent[n.first as usize + 1] = k as u32;
            } else {
                for &i in &bvh.indices[n.first as usize..(n.first + n.count) as usize] {
                    leaf_of[i as usize] = k as u32;
                }
            }
        }
        // A box's floor, so that a flat or degenerate one is not asked to stay zero.
        let floor = bvh.nodes.first().map_or(0.0, |r| box_of(r).half_area()) * 1e-6;
        let built_area = bvh
            .nodes
            .iter()
            .map(|n| box_of(n).half_area().max(floor))
            .collect();
        Self {
            bvh,
            triangles,
            leaf_of,
            parent,
            built_area,
            refitted: false,
        }
    }

    /// Moves triangles (by id) and refits: the nodes whose boxes changed, in order; none when
    /// a build is wanted instead (a moved triangle not finite, or one the build left out; a
    /// box past `GROWTH` times its built area). The hierarchy is then not to be used.
    pub fn refit(&mut self, moved: &[(usize, [Vec3; 3])]) -> Option<Vec<u32>> {
        let mut dirty = BTreeSet::new();
        for &(id, t) in moved {
            let leaf = *self.leaf_of.get(id)?;
            if leaf == NONE || !t.iter().all(|p| p.is_finite()) {
                return None;
            }
            self.triangles[id] = t;
            dirty.insert(leaf);
        }
        let mut changed = Vec::new();
        // Deepest first: a node's children come after it, so the largest index is never an
        // ancestor of another in the set (and each node is met once).
        while let Some(k) = dirty.pop_last() {
            let n = self.bvh.nodes[k as usize];
            let b = if n.count == INNER {
                let first = n.first as usize;
                box_of(&self.bvh.nodes[first]).grow(box_of(&self.bvh.nodes[first + 1]))
            } else {
                let leaf = &self.bvh.indices[n.first as usize..(n.first + n.count) as usize];
                leaf.iter().fold(Bounds::EMPTY, |b, &i| {
                    b.grow(Bounds::of(self.triangles[i as usize]))
                })
            };
            if b == box_of(&n) {
                continue;
            }
            if b.half_area() > GROWTH * self.built_area[k as usize] {
                return None;
            }
            let node = &mut self.bvh.nodes[k as usize];
            node.min = b.min.to_array();
            node.max = b.max.to_array();
            changed.push(k);
            if self.parent[k as usize] != NONE {
                dirty.insert(self.parent[k as usize]);
            }
        }
        self.refitted |= !changed.is_empty();
        changed.reverse();
        Some(changed)
    }
}

fn box_of(n: &super::BvhNode) -> Bounds {
    Bounds {
        min: n.min.into(),
        max: n.max.into(),
    }
}

#[cfg(test)]
mod tests {
    use super::super::build::tests::hit;
    use super::*;

    /// Nearest hit by walking every leaf whose box and ancestors' boxes the ray enters.
    fn walk(r: &Refittable, o: Vec3, d: Vec3, node: usize) -> Option<f32> {
        let n = r.bvh.nodes[node];
        let inv = d.recip();
        let t0 = (Vec3::from(n.min) - o) * inv;
        let t1 = (Vec3::from(n.max) - o) * inv;
        if t0.min(t1).max_element().max(0.0) > t0.max(t1).min_element() {
            return None;
        }
        if n.count == INNER {
            let (a, b) = (
                walk(r, o, d, n.first as usize),
                walk(r, o, d, n.first as usize + 1),
            );
            return a.into_iter().chain(b).reduce(f32::min);
        }
        r.bvh.indices[n.first as usize..(n.first + n.count) as usize]
            .iter()
            .filter_map(|&i| hit(o, d, r.triangles[i as usize]))
            .reduce(f32::min)
    }

    /// A grid of small triangles; one patch of them moves a little: only its leaves and
    /// their ancestors change, and every ray still finds what brute force finds.
    #[test]
    fn a_moved_patch_changes_its_paths_to_the_root_and_is_still_found() {
        let triangles: Vec<[Vec3; 3]> = (0..1024)
            .map(|k| {
                let p = Vec3::new((k % 32) as f32, (k / 32) as f32, 0.0);
                [p, p + Vec3::X * 0.9, p + Vec3::Y * 0.9]
            })
            .collect();
        let mut r = Refittable::build(triangles.clone());
        let patch: Vec<(usize, [Vec3; 3])> = (0..1024)
            .filter(|k| k % 32 < 4 && k / 32 < 4)
            .map(|k| (k, triangles[k].map(|p| p + Vec3::new(0.3, 0.2, 0.5))))
            .collect();
        let changed = r.refit(&patch).expect("a small move refits");
        assert!(r.refitted);
        assert!(
            !changed.is_empty() && changed.len() * 20 < r.bvh.nodes.len(),
            "{} of {} nodes changed",
            changed.len(),
            r.bvh.nodes.len()
        );
        let mut moved = triangles.clone();
        for &(k, t) in &patch {
            moved[k] = t;
        }
        for k in 0..300 {
            // Off the grid's lines, never parallel to an axis (the test's slabs are plain).
            let o = Vec3::new(
                (k % 17) as f32 * 0.37 + 0.013,
                (k % 13) as f32 * 0.41 + 0.017,
                -2.0,
            );
            let d = Vec3::new(
                0.05 * (k % 5) as f32 + 0.011,
                0.04 * (k % 7) as f32 + 0.007,
                1.0,
            );
            let brute = moved.iter().filter_map(|t| hit(o, d, *t)).reduce(f32::min);
            assert_eq!(walk(&r, o, d, 0), brute, "ray {k}");
        }
        // Far away, a box grows past its bound: a build is asked for.
        let far: Vec<_> = patch
            .iter()
            .map(|&(k, t)| (k, t.map(|p| p + Vec3::Z * 500.0)))
            .collect();
        assert!(r.refit(&far).is_none());
        // So is a triangle no longer finite.
        let mut fresh = Refittable::build(triangles);
        assert!(fresh.refit(&[(5, [Vec3::NAN; 3])]).is_none());
        assert!(fresh.refit(&[(2000, [Vec3::ZERO; 3])]).is_none());
    }
}
