//! Triangles as the GPU stores them: positions and material as they are, normals octahedral
//! in 2 × 16 bits, no padding (52 bytes against 96), so that 2.5 million triangles fit a
//! 128 MiB storage binding. `triangle_at` in shaders/scene/scene.wgsl unpacks them.

use bevy::math::{Vec2, Vec3};
use bytemuck::{Pod, Zeroable};

use super::GpuTriangle;

/// One stored triangle (52 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PackedTriangle {
    pub positions: [[f32; 3]; 3],
    pub material: u32,
    /// Octahedral unit normals, as WGSL's `unpack2x16snorm` reads them.
    pub normals: [u32; 3],
}

impl From<&GpuTriangle> for PackedTriangle {
    fn from(t: &GpuTriangle) -> Self {
        Self {
            positions: [t.position_a, t.position_b, t.position_c],
            material: t.material,
            normals: [t.normal_a, t.normal_b, t.normal_c].map(|n| pack_normal(Vec3::from(n))),
        }
    }
}

/// A unit vector onto the octahedron, then into two snorm16 (x in the low half).
pub fn pack_normal(n: Vec3) -> u32 {
    let n = n / (n.x.abs() + n.y.abs() + n.z.abs()).max(1e-20);
    let mut e = Vec2::new(n.x, n.y);
    if n.z < 0.0 {
        e = (Vec2::ONE - Vec2::new(e.y, e.x).abs()) * sign(e);
    }
    let snorm = |v: f32| ((v.clamp(-1.0, 1.0) * 32767.0).round() as i16) as u16 as u32;
    snorm(e.x) | (snorm(e.y) << 16)
}

/// What the shader's `unpack_normal` gives.
#[cfg(test)]
fn unpack_normal(v: u32) -> Vec3 {
    let snorm = |h: u32| ((h as u16 as i16) as f32 / 32767.0).max(-1.0);
    let e = Vec2::new(snorm(v & 0xffff), snorm(v >> 16));
    let z = 1.0 - e.x.abs() - e.y.abs();
    let xy = if z < 0.0 {
        (Vec2::ONE - Vec2::new(e.y, e.x).abs()) * sign(e)
    } else {
        e
    };
    Vec3::new(xy.x, xy.y, z).normalize()
}

/// ±1 by sign, +1 at zero as in the shader (glam's `signum` gives −1 at −0).
fn sign(v: Vec2) -> Vec2 {
    Vec2::select(v.cmpge(Vec2::ZERO), Vec2::ONE, Vec2::NEG_ONE)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normals_survive_packing_within_a_twentieth_of_a_degree() {
        let mut worst: f32 = 0.0;
        for i in 0..2000 {
            // A spiral over the sphere, and the axes and diagonals.
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / 2000.0;
            let phi = i as f32 * 2.399_963;
            let r = (1.0 - z * z).sqrt();
            let n = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            for n in [
                n,
                Vec3::X,
                -Vec3::Y,
                -Vec3::Z,
                Vec3::new(-1.0, -1.0, -1.0).normalize(),
            ] {
                let back = unpack_normal(pack_normal(n));
                worst = worst.max(n.angle_between(back).to_degrees());
            }
        }
        assert!(worst < 0.05, "{worst}°");
        assert_eq!(std::mem::size_of::<PackedTriangle>(), 52);
    }
}
