//! Every visible `Mesh3d` + `StandardMaterial` to world-space triangles, materials, lights and
//! emitters in flat tables, rebuilt only when something in the scene changed.

use std::sync::Arc;

use bevy::ecs::entity::EntityHashSet;
use bevy::platform::collections::HashMap;
use bevy::prelude::*;

use super::{GpuEmitter, GpuMaterial, GpuTriangle, RppmScene, SceneData, lights, luminance, mesh};

/// Warnings already given, so each is logged once.
#[derive(Resource, Default)]
pub(super) struct ExtractionWarnings {
    meshes: bevy::platform::collections::HashSet<AssetId<Mesh>>,
    entities: EntityHashSet,
}

type MeshChanged = Or<(
    Changed<Mesh3d>,
    Changed<MeshMaterial3d<StandardMaterial>>,
    Changed<GlobalTransform>,
    Changed<InheritedVisibility>,
)>;

type LightChanged = Or<(
    Changed<PointLight>,
    Changed<SpotLight>,
    Changed<DirectionalLight>,
    Changed<GlobalTransform>,
)>;

type AnyLight = Or<(With<PointLight>, With<SpotLight>, With<DirectionalLight>)>;

type MeshItem<'a> = (
    Entity,
    &'a Mesh3d,
    &'a MeshMaterial3d<StandardMaterial>,
    &'a GlobalTransform,
    Option<&'a InheritedVisibility>,
);

#[expect(clippy::too_many_arguments, reason = "one query per kind of change")]
pub(super) fn extract_scene(
    meshes_q: Query<MeshItem>,
    changed_meshes: Query<(), (With<Mesh3d>, MeshChanged)>,
    changed_lights: Query<(), (AnyLight, LightChanged)>,
    mut removed_meshes: RemovedComponents<Mesh3d>,
    mut removed_point: RemovedComponents<PointLight>,
    mut removed_spot: RemovedComponents<SpotLight>,
    mut removed_dir: RemovedComponents<DirectionalLight>,
    mut mesh_events: MessageReader<AssetEvent<Mesh>>,
    mut material_events: MessageReader<AssetEvent<StandardMaterial>>,
    lights_q: lights::LightQueries,
    mesh_assets: Res<Assets<Mesh>>,
    material_assets: Res<Assets<StandardMaterial>>,
    mut warnings: ResMut<ExtractionWarnings>,
    mut scene: ResMut<RppmScene>,
) {
    let dirty = !changed_meshes.is_empty()
        || !changed_lights.is_empty()
        || removed_meshes.read().count() > 0
        || removed_point.read().count() + removed_spot.read().count() + removed_dir.read().count()
            > 0
        || mesh_events.read().count() > 0
        || material_events.read().count() > 0;
    if !dirty {
        return;
    }
    let mut data = SceneData::default();
    let mut material_index: HashMap<AssetId<StandardMaterial>, u32> = HashMap::default();
    for (entity, mesh3d, material3d, transform, visibility) in &meshes_q {
        if visibility.is_some_and(|v| !v.get()) {
            continue;
        }
        let Some(material) = material_assets.get(&material3d.0) else {
            continue;
        };
        let Some(mesh) = mesh_assets.get(&mesh3d.0) else {
            continue;
        };
        let affine = transform.affine();
        if !affine.is_finite() {
            if warnings.entities.insert(entity) {
                warn!("bevy_rppm: entity {entity} has a non-finite transform; it is left out");
            }
            continue;
        }
        let next = data.materials.len() as u32;
        let index = *material_index.entry(material3d.0.id()).or_insert(next);
        if index == next {
            data.materials.push(material_to_gpu(material));
        }
        if let Err(reason) = mesh::append_triangles(mesh, &affine, index, &mut data.triangles)
            && warnings.meshes.insert(mesh3d.0.id())
        {
            warn!(
                "bevy_rppm: mesh {:?} of entity {entity} is left out: {reason}",
                mesh3d.0.id()
            );
        }
    }
    data.bounds = bounds(&data.triangles);
    lights::collect_lights(&lights_q, &mut data);
    collect_emitters(&mut data);
    data.light_cdf = cdf(data
        .lights
        .iter()
        .map(|l| l.radiance[3])
        .chain(data.emitters.iter().map(|e| e.power)));
    scene.data = Arc::new(data);
    scene.epoch += 1;
}

fn material_to_gpu(m: &StandardMaterial) -> GpuMaterial {
    let base = m.base_color.to_linear();
    GpuMaterial {
        base_color: [base.red, base.green, base.blue, base.alpha],
        emissive: [m.emissive.red, m.emissive.green, m.emissive.blue, 0.0],
        metallic: m.metallic.clamp(0.0, 1.0),
        perceptual_roughness: m.perceptual_roughness.clamp(0.0, 1.0),
        reflectance: m.reflectance.clamp(0.0, 1.0),
        specular_transmission: m.specular_transmission.clamp(0.0, 1.0),
        ior: if m.ior.is_finite() && m.ior >= 1.0 {
            m.ior
        } else {
            1.5
        },
        flags: m.double_sided as u32,
        _pad: [0; 2],
    }
}

fn bounds(triangles: &[GpuTriangle]) -> (Vec3, Vec3) {
    let mut points = triangles.iter().flat_map(GpuTriangle::positions);
    let Some(first) = points.next() else {
        return (Vec3::ZERO, Vec3::ZERO);
    };
    points.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p)))
}

fn collect_emitters(data: &mut SceneData) {
    for (i, t) in data.triangles.iter().enumerate() {
        let m = &data.materials[t.material as usize];
        let radiance = luminance([m.emissive[0], m.emissive[1], m.emissive[2]]);
        let area = t.area();
        let power = std::f32::consts::PI * radiance * area;
        if power > 0.0 && power.is_finite() {
            data.emitters.push(GpuEmitter {
                triangle: i as u32,
                area,
                power,
                cdf: 0.0,
            });
        }
    }
    let cdf = cdf(data.emitters.iter().map(|e| e.power));
    for (e, c) in data.emitters.iter_mut().zip(cdf) {
        e.cdf = c;
    }
}

/// Inclusive normalised CDF; empty or all-zero weights give an empty or uniform CDF.
fn cdf(weights: impl Iterator<Item = f32>) -> Vec<f32> {
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
}
