//! The emissive triangles as area lights: one emitter per triangle (per part of a textured
//! one), its power, and where its photons can land ([`receivers`]).

use std::sync::Arc;

use bevy::prelude::*;

use super::textures::PackedTexture;
use super::{GpuEmitter, GpuTriangle, SceneData, luminance, parts, receivers};

/// Emissive instances × instances whose receivers extraction looks for, at most.
const MAX_RECEIVER_TESTS: usize = 1 << 22;

fn luminance_of(m: &super::GpuMaterial) -> f32 {
    luminance([m.emissive[0], m.emissive[1], m.emissive[2]])
}

pub(super) fn collect_emitters(
    data: &mut SceneData,
    textures: &[Arc<PackedTexture>],
    instance_bounds: &[Option<(Vec3, Vec3)>],
) {
    // Receivers are known only where every instance's bounds are, and looked for while the
    // emissive instances × instances stay few (extraction runs every frame of an animation).
    let emissive = (data.instances.iter())
        .filter(|i| luminance_of(&data.materials[i.material as usize]) > 0.0)
        .count();
    let boxes: Option<Vec<(Vec3, Vec3)>> = instance_bounds.iter().copied().collect();
    let boxes = boxes.filter(|b| emissive * b.len() <= MAX_RECEIVER_TESTS);
    // Cuts a textured emissive triangle may get: as many as keep all their parts together
    // within parts::MAX_PARTS.
    let radiance = luminance_of;
    let textured: usize = data
        .instances
        .iter()
        .filter(|i| {
            let m = &data.materials[i.material as usize];
            textures.get(m.textures[2] as usize).is_some() && radiance(m) > 0.0
        })
        .map(|i| data.meshes[i.mesh as usize].triangles.len())
        .sum();
    let most = parts::most_cuts(textured);
    for (own, instance) in data.instances.iter().enumerate() {
        let m = &data.materials[instance.material as usize];
        let radiance = radiance(m);
        if radiance <= 0.0 {
            continue;
        }
        let mesh = &data.meshes[instance.mesh as usize];
        let plane = boxes.as_ref().and_then(|boxes| {
            let placed = mesh.triangles.iter().map(|t| instance.place(t).positions());
            receivers::emitter_plane(placed, boxes, own)
        });
        let toward = |placed: &GpuTriangle| {
            let [a, b, c] = placed.positions();
            plane.map_or([0.0; 4], |p| p.toward((b - a).cross(c - a)))
        };
        let texture = textures.get(m.textures[2] as usize);
        let transform = Mat2::from_cols_array(&m.uv_transform);
        let offset = Vec2::from_slice(&m.uv_offset);
        for (k, local) in mesh.triangles.iter().enumerate() {
            let placed = instance.place(local);
            let area = placed.area();
            let toward = toward(&placed);
            let triangle = instance.first_world + k as u32;
            let textured = texture.zip(mesh.attributes.get(k));
            let Some((packed, attributes)) = textured else {
                push_emitter(&mut data.emitters, (triangle, 0), area, radiance, toward);
                continue;
            };
            // Texture coordinates at world barycentrics, the corners in placed order.
            let [a, b, c] = instance.placed_order(attributes.uv.map(Vec2::from));
            let uv = |w: Vec2| transform * (a + (b - a) * w.x + (c - a) * w.y) + offset;
            let texels = (transform * (b - a)).perp_dot(transform * (c - a)).abs()
                * 0.5
                * (packed.width * packed.height) as f32;
            // Photons leave each part in proportion to the texture's mean over it, from a few
            // points (the shaders weight each by the texel it leaves from, so a rough mean
            // costs noise, never bias; a floor keeps every texel reachable).
            let level = parts::level_for(texels).min(most);
            let share = area / (1u32 << (2 * level)) as f32;
            for part in parts::parts(level) {
                let [p, q, r] = parts::corners(part);
                let mean = [
                    [4.0, 1.0, 1.0],
                    [1.0, 4.0, 1.0],
                    [1.0, 1.0, 4.0],
                    [2.0, 2.0, 2.0],
                ]
                .iter()
                .map(|w| {
                    let at = (p * w[0] + q * w[1] + r * w[2]) / 6.0;
                    luminance(packed.sample(uv(at)).truncate().to_array())
                })
                .sum::<f32>()
                    / 4.0;
                let power = radiance * mean.max(0.01);
                push_emitter(&mut data.emitters, (triangle, part), share, power, toward);
            }
        }
    }
    let cdf = cdf(data.emitters.iter().map(|e| e.power));
    for (e, c) in data.emitters.iter_mut().zip(cdf) {
        e.cdf = c;
    }
}

impl SceneData {
    /// Whether an emissive instance is more than a quad (a ball, a box, a disc). Drawn a
    /// triangle at a time by power, its nearest triangles come too rarely for a surface close
    /// by; a ray drawn by cosine finds them (`EMITTER_RAYS`). A quad's two triangles need none.
    pub fn has_many_faced_emitters(&self) -> bool {
        self.instances.iter().any(|i| {
            luminance_of(&self.materials[i.material as usize]) > 0.0
                && self.meshes[i.mesh as usize].triangles.len() > 2
        })
    }
}

/// An emitter of `radiance` (luminance) over `area` of a triangle's part, if it emits, its
/// photons leaving `toward` a sphere (radius 0: over the hemisphere).
fn push_emitter(
    emitters: &mut Vec<GpuEmitter>,
    (triangle, part): (u32, u32),
    area: f32,
    radiance: f32,
    toward: [f32; 4],
) {
    let power = std::f32::consts::PI * radiance * area;
    if power > 0.0 && power.is_finite() {
        emitters.push(GpuEmitter {
            triangle,
            part,
            area,
            power,
            cdf: 0.0,
            toward,
        });
    }
}

/// Inclusive normalised CDF; empty or all-zero weights give an empty or uniform CDF.
pub(super) fn cdf(weights: impl Iterator<Item = f32>) -> Vec<f32> {
    let w: Vec<f32> = weights
        .map(|w| if w.is_finite() { w.max(0.0) } else { 0.0 })
        .collect();
    let total: f64 = w.iter().map(|&x| x as f64).sum();
    let n = w.len();
    let mut acc = 0.0f64;
    w.iter()
        .enumerate()
        .map(|(i, &x)| {
            acc += if total > 0.0 {
                x as f64 / total
            } else {
                1.0 / n as f64
            };
            if i + 1 == n { 1.0 } else { acc as f32 }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cdf_is_normalised_and_monotone() {
        let c = cdf([1.0, 3.0, 0.0, 4.0].into_iter());
        assert_eq!(c.len(), 4);
        assert!((c[0] - 0.125).abs() < 1e-6 && (c[1] - 0.5).abs() < 1e-6);
        assert_eq!(c[2], c[1]);
        assert_eq!(c[3], 1.0);
        assert_eq!(cdf([0.0, 0.0].into_iter()), vec![0.5, 1.0]);
        assert!(cdf(std::iter::empty()).is_empty());
    }

    /// A quad's two triangles are drawn well by power; more faces need the cosine ray.
    #[test]
    fn emitters_of_more_than_a_quad_are_many_faced() {
        let mesh = |n| {
            Arc::new(super::super::SceneMesh {
                triangles: vec![GpuTriangle::default(); n],
                ..default()
            })
        };
        let glowing = super::super::GpuMaterial {
            emissive: [1.0, 1.0, 1.0, 0.0],
            ..default()
        };
        let instance =
            |m| super::super::GpuInstance::new(bevy::math::Affine3A::IDENTITY, 0, m).unwrap();
        let scene = |triangles, material: u32| SceneData {
            meshes: vec![mesh(triangles)],
            instances: vec![instance(material)],
            materials: vec![glowing, super::super::GpuMaterial::default()],
            ..default()
        };
        assert!(!scene(2, 0).has_many_faced_emitters());
        assert!(scene(3, 0).has_many_faced_emitters());
        assert!(!scene(300, 1).has_many_faced_emitters());
    }
}
