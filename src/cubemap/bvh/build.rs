//! A bounding-volume hierarchy over triangles, built on the CPU by binned SAH: the peer the
//! deep cubemap is measured against (what a GPU without ray-tracing cores would otherwise
//! trace a dynamic scene with). Pure maths: no GPU here.

use bevy::math::Vec3;
use bytemuck::{Pod, Zeroable};

/// Triangles a leaf holds at most (more only where the hierarchy would grow too deep).
const LEAF_TRIANGLES: usize = 4;
/// SAH bins along the longest axis of a node's centroids.
const BINS: usize = 12;
/// Deepest node: the GPU walk's stack holds this many entries (`BVH_STACK` in
/// trace.wgsl).
pub const MAX_DEPTH: usize = 48;

/// `count` of an inner node.
pub const INNER: u32 = u32::MAX;

/// A node as the GPU reads it (`BvhNode` in trace.wgsl): a leaf holds triangles
/// `first..first + count` of [`Bvh::indices`]; an inner node (`count` = [`INNER`]) has
/// children `first` and `first + 1`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct BvhNode {
    pub min: [f32; 3],
    pub first: u32,
    pub max: [f32; 3],
    pub count: u32,
}

/// The hierarchy: nodes (the root first) and the triangle ids its leaves list.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    pub nodes: Vec<BvhNode>,
    pub indices: Vec<u32>,
}

#[derive(Clone, Copy, PartialEq)]
pub(super) struct Bounds {
    pub min: Vec3,
    pub max: Vec3,
}

impl Bounds {
    pub const EMPTY: Self = Self {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn of([a, b, c]: [Vec3; 3]) -> Self {
        Self {
            min: a.min(b).min(c),
            max: a.max(b).max(c),
        }
    }

    pub fn grow(self, other: Self) -> Self {
        Self {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    pub fn half_area(self) -> f32 {
        let e = (self.max - self.min).max(Vec3::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }
}

impl Bvh {
    /// Builds the hierarchy over `triangles` (id = position in the slice). Triangles with a
    /// non-finite corner are left out: no ray can hit them.
    pub fn build(triangles: &[[Vec3; 3]]) -> Self {
        let bounds: Vec<Bounds> = triangles
            .iter()
            .map(|[a, b, c]| Bounds {
                min: a.min(*b).min(*c),
                max: a.max(*b).max(*c),
            })
            .collect();
        let mut indices: Vec<u32> = (0..triangles.len() as u32)
            .filter(|&i| triangles[i as usize].iter().all(|p| p.is_finite()))
            .collect();
        let mut nodes = vec![BvhNode::default()];
        // (node, first index, end index, depth)
        let mut work = vec![(0usize, 0usize, indices.len(), 0usize)];
        while let Some((node, start, end, depth)) = work.pop() {
            let span = &mut indices[start..end];
            let all = span
                .iter()
                .fold(Bounds::EMPTY, |b, &i| b.grow(bounds[i as usize]));
            nodes[node] = BvhNode {
                min: all.min.to_array(),
                first: start as u32,
                max: all.max.to_array(),
                count: span.len() as u32,
            };
            if span.len() <= LEAF_TRIANGLES || depth + 1 >= MAX_DEPTH {
                continue;
            }
            let Some(mid) = split(span, &bounds) else {
                continue;
            };
            let left = nodes.len();
            nodes.push(BvhNode::default());
            nodes.push(BvhNode::default());
            nodes[node].first = left as u32;
            nodes[node].count = INNER;
            work.push((left, start, start + mid, depth + 1));
            work.push((left + 1, start + mid, end, depth + 1));
        }
        Self { nodes, indices }
    }

    pub fn bytes(&self) -> u64 {
        (self.nodes.len() * size_of::<BvhNode>() + self.indices.len() * 4) as u64
    }
}

/// Reorders `span` into two non-empty halves by the cheapest binned-SAH split along its
/// centroids' longest axis (by count where the centroids coincide); the first half's length,
/// or none where a leaf is cheaper.
fn split(span: &mut [u32], bounds: &[Bounds]) -> Option<usize> {
    let centre = |i: u32| {
        let b = bounds[i as usize];
        (b.min + b.max) * 0.5
    };
    let (lo, hi) = span.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), &i| (lo.min(centre(i)), hi.max(centre(i))),
    );
    let extent = hi - lo;
    let axis = extent.max_position();
    if extent[axis] <= 0.0 {
        let mid = span.len() / 2;
        return Some(mid);
    }
    let bin_of = |i: u32| {
        let f = (centre(i)[axis] - lo[axis]) / extent[axis];
        ((f * BINS as f32) as usize).min(BINS - 1)
    };
    let mut bins = [(Bounds::EMPTY, 0usize); BINS];
    for &i in span.iter() {
        let b = &mut bins[bin_of(i)];
        *b = (b.0.grow(bounds[i as usize]), b.1 + 1);
    }
    // Cost of splitting after bin k: left area × count + right area × count.
    let mut right = [0.0f32; BINS];
    let (mut acc, mut n) = (Bounds::EMPTY, 0);
    for k in (1..BINS).rev() {
        acc = acc.grow(bins[k].0);
        n += bins[k].1;
        right[k] = acc.half_area() * n as f32;
    }
    let (mut acc, mut n) = (Bounds::EMPTY, 0);
    let mut best = (f32::INFINITY, 0);
    for k in 0..BINS - 1 {
        acc = acc.grow(bins[k].0);
        n += bins[k].1;
        let cost = acc.half_area() * n as f32 + right[k + 1];
        if n > 0 && n < span.len() && cost < best.0 {
            best = (cost, k);
        }
    }
    if !best.0.is_finite() {
        return Some(span.len() / 2);
    }
    let whole = bins.iter().fold(Bounds::EMPTY, |b, bin| b.grow(bin.0));
    // A leaf costs a test per triangle; a split one box test per child plus its triangles.
    if span.len() <= 2 * LEAF_TRIANGLES && best.0 >= whole.half_area() * span.len() as f32 {
        return None;
    }
    let mut mid = 0;
    for k in 0..span.len() {
        if bin_of(span[k]) <= best.1 {
            span.swap(k, mid);
            mid += 1;
        }
    }
    Some(mid)
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// Möller–Trumbore distance, or none.
    pub(in crate::cubemap::bvh) fn hit(o: Vec3, d: Vec3, [a, b, c]: [Vec3; 3]) -> Option<f32> {
        let (e1, e2) = (b - a, c - a);
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-12 {
            return None;
        }
        let s = o - a;
        let u = s.dot(p) / det;
        let q = s.cross(e1);
        let v = d.dot(q) / det;
        let t = e2.dot(q) / det;
        (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 1e-6).then_some(t)
    }

    fn slab(o: Vec3, d: Vec3, n: &BvhNode) -> bool {
        let inv = d.recip();
        let t0 = (Vec3::from(n.min) - o) * inv;
        let t1 = (Vec3::from(n.max) - o) * inv;
        let near = t0.min(t1).max_element().max(0.0);
        near <= t0.max(t1).min_element()
    }

    /// The nearest hit by walking the hierarchy.
    fn walk(bvh: &Bvh, tris: &[[Vec3; 3]], o: Vec3, d: Vec3) -> Option<f32> {
        let mut best: Option<f32> = None;
        let mut stack = vec![0usize];
        while let Some(k) = stack.pop() {
            let n = &bvh.nodes[k];
            if !slab(o, d, n) {
                continue;
            }
            if n.count != INNER {
                for &i in &bvh.indices[n.first as usize..(n.first + n.count) as usize] {
                    if let Some(t) = hit(o, d, tris[i as usize]) {
                        best = Some(best.map_or(t, |b| b.min(t)));
                    }
                }
            } else {
                stack.extend([n.first as usize, n.first as usize + 1]);
            }
        }
        best
    }

    fn random_triangles(count: usize) -> Vec<[Vec3; 3]> {
        let mut s = 12345u32;
        let mut r = || {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            s as f32 / u32::MAX as f32
        };
        (0..count)
            .map(|_| {
                let c = Vec3::new(r(), r(), r()) * 10.0;
                let e = 0.05 + r();
                [
                    c,
                    c + Vec3::new(e, r() * e, 0.0),
                    c + Vec3::new(0.0, e, r() * e),
                ]
            })
            .collect()
    }

    #[test]
    fn every_triangle_in_one_leaf_inside_its_bounds() {
        let tris = random_triangles(3000);
        let bvh = Bvh::build(&tris);
        let mut seen = vec![0; tris.len()];
        let mut depth = vec![0usize; bvh.nodes.len()];
        for (k, n) in bvh.nodes.iter().enumerate() {
            if n.count != INNER {
                for &i in &bvh.indices[n.first as usize..(n.first + n.count) as usize] {
                    seen[i as usize] += 1;
                    for p in tris[i as usize] {
                        assert!(p.cmpge(n.min.into()).all() && p.cmple(n.max.into()).all());
                    }
                }
            } else {
                for c in [n.first as usize, n.first as usize + 1] {
                    let child = &bvh.nodes[c];
                    assert!(Vec3::from(child.min).cmpge(n.min.into()).all());
                    assert!(Vec3::from(child.max).cmple(n.max.into()).all());
                    depth[c] = depth[k] + 1;
                }
            }
        }
        assert!(seen.iter().all(|&s| s == 1));
        assert!(depth.iter().all(|&d| d < MAX_DEPTH));
        assert!(bvh.nodes.len() < tris.len());
    }

    #[test]
    fn walk_finds_the_brute_force_hit() {
        let tris = random_triangles(500);
        let bvh = Bvh::build(&tris);
        let mut agree = 0;
        for k in 0..400 {
            let o = Vec3::new(5.0, 5.0, -3.0 + (k % 7) as f32);
            let a = k as f32 * 0.37;
            let d = Vec3::new(a.cos(), (a * 1.3).sin(), 0.6).normalize();
            let brute = tris.iter().filter_map(|t| hit(o, d, *t)).reduce(f32::min);
            agree += (walk(&bvh, &tris, o, d) == brute) as usize;
        }
        assert_eq!(agree, 400);
    }

    #[test]
    fn coincident_and_broken_triangles() {
        let same = vec![[Vec3::ZERO, Vec3::X, Vec3::Y]; 100];
        let bvh = Bvh::build(&same);
        assert_eq!(bvh.indices.len(), 100);
        let broken = vec![[Vec3::NAN, Vec3::X, Vec3::Y]; 3];
        let bvh = Bvh::build(&broken);
        assert!(bvh.indices.is_empty() && bvh.nodes.len() == 1);
        assert!(Bvh::build(&[]).indices.is_empty());
    }
}
