//! Scene extraction: every visible `Mesh3d` + `StandardMaterial` becomes world-space triangles,
//! materials and lights in flat tables, rebuilt only when something in the scene changed.
//!
//! This runs in the main world (so games and tests can read [`RppmScene`]); the render world
//! receives the tables as one `Arc` and uploads them (see [`gpu`]).

pub mod gpu;
mod lights;
mod mesh;

use std::sync::Arc;

use bevy::camera::visibility::VisibilitySystems;
use bevy::ecs::entity::EntityHashSet;
use bevy::platform::collections::HashMap;
use bevy::prelude::*;
use bevy::render::extract_resource::ExtractResource;
use bevy::transform::TransformSystems;
use bytemuck::{Pod, Zeroable};

pub use lights::{LightKind, spot_cone_fraction};

use crate::settings::PhotonMapping;

/// One world-space triangle as the GPU reads it (96 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangle {
    pub position_a: [f32; 3],
    /// Index into [`SceneData::materials`].
    pub material: u32,
    pub position_b: [f32; 3],
    pub _pad_b: u32,
    pub position_c: [f32; 3],
    pub _pad1: u32,
    pub normal_a: [f32; 3],
    pub _pad2: u32,
    pub normal_b: [f32; 3],
    pub _pad3: u32,
    pub normal_c: [f32; 3],
    pub _pad4: u32,
}

impl GpuTriangle {
    pub fn positions(&self) -> [Vec3; 3] {
        [
            self.position_a.into(),
            self.position_b.into(),
            self.position_c.into(),
        ]
    }

    /// Area in m².
    pub fn area(&self) -> f32 {
        let [a, b, c] = self.positions();
        0.5 * (b - a).cross(c - a).length()
    }
}

/// A `StandardMaterial` reduced to what the light transport uses (64 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMaterial {
    /// Linear RGB base colour (albedo), alpha in w.
    pub base_color: [f32; 4],
    /// Emitted radiance, linear RGB (W·sr⁻¹·m⁻²); w unused.
    pub emissive: [f32; 4],
    pub metallic: f32,
    pub perceptual_roughness: f32,
    /// Bevy's reflectance: F0 = 0.16·reflectance² for dielectrics.
    pub reflectance: f32,
    pub specular_transmission: f32,
    pub ior: f32,
    /// Bit 0: double-sided.
    pub flags: u32,
    pub _pad: [u32; 2],
}

/// A punctual light (64 bytes). Radiometric units, photometric numbers taken as radiometric.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuLight {
    /// [`LightKind`] as u32.
    pub kind: u32,
    /// First layer of this light's shadow views (6 for point and spot, 1 for directional).
    pub shadow_layer: u32,
    /// cos of the spot's inner and outer half-angles.
    pub cos_inner: f32,
    pub cos_outer: f32,
    /// Position (point, spot), w unused.
    pub position: [f32; 4],
    /// Direction light travels (spot, directional), unit length.
    pub direction: [f32; 4],
    /// Radiant intensity W/sr (point, spot) or irradiance W/m² (directional), linear RGB; w
    /// holds the power used to split photons (W, luminance-weighted).
    pub radiance: [f32; 4],
}

/// An emissive triangle, an area light (16 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuEmitter {
    pub triangle: u32,
    /// Area in m².
    pub area: f32,
    /// Emitted power π·L·A (W, luminance-weighted).
    pub power: f32,
    /// Cumulative distribution over emitters (inclusive), in (0, 1].
    pub cdf: f32,
}

/// The scene as flat tables, in world space.
#[derive(Clone, Debug, Default)]
pub struct SceneData {
    pub triangles: Vec<GpuTriangle>,
    pub materials: Vec<GpuMaterial>,
    pub lights: Vec<GpuLight>,
    pub emitters: Vec<GpuEmitter>,
    /// Photon-emission CDF over `lights` then `emitters`, by power (inclusive, last = 1).
    pub light_cdf: Vec<f32>,
    /// Axis-aligned bounds of all triangles (min, max); zero-sized when empty.
    pub bounds: (Vec3, Vec3),
}

impl SceneData {
    /// Total emitted power (luminance-weighted W) of every light and emitter.
    pub fn total_power(&self) -> f32 {
        self.lights.iter().map(|l| l.radiance[3]).sum::<f32>()
            + self.emitters.iter().map(|e| e.power).sum::<f32>()
    }

    /// Centre and radius of a sphere around the bounds.
    pub fn bounding_sphere(&self) -> (Vec3, f32) {
        let (lo, hi) = self.bounds;
        ((lo + hi) * 0.5, ((hi - lo) * 0.5).length())
    }

    /// Whether some surface only reflects or refracts specularly (a mirror, clear glass): then
    /// camera paths go on past the G-buffer (`is_specular` in local_illumination.wgsl).
    pub fn has_specular_surfaces(&self) -> bool {
        self.materials.iter().any(|m| {
            let diffuse = (1.0 - m.metallic) * (1.0 - m.specular_transmission);
            let albedo = luminance([m.base_color[0], m.base_color[1], m.base_color[2]]);
            m.perceptual_roughness < DELTA_ROUGHNESS && diffuse * albedo <= 0.0
        })
    }

    /// Which scattering lobes the scene's materials have: the shader defs of the tracing
    /// stages (`GLOSSY`, `MIRRORS`, `REFRACTION`), so a scene compiles only its own paths.
    pub fn path_features(&self) -> Vec<&'static str> {
        let (mut glossy, mut mirrors, mut refraction) = (false, false, false);
        for m in &self.materials {
            let colour = m.base_color[..3].iter().any(|&c| c > 0.0);
            if m.perceptual_roughness >= DELTA_ROUGHNESS {
                glossy |= m.reflectance > 0.0 || (m.metallic > 0.0 && colour);
            } else {
                mirrors |= m.metallic > 0.0 && colour;
                refraction |= m.specular_transmission * (1.0 - m.metallic) > 0.0;
            }
        }
        [
            (glossy, "GLOSSY"),
            (mirrors, "MIRRORS"),
            (refraction, "REFRACTION"),
        ]
        .into_iter()
        .filter_map(|(on, def)| on.then_some(def))
        .collect()
    }

    /// The largest probability that a photon goes on after a hit, over the scene's materials
    /// (the Russian roulette of photon.wgsl: diffuse, glossy, mirror and glass albedos).
    pub fn max_scatter_probability(&self) -> f32 {
        self.materials
            .iter()
            .map(|m| {
                let rgb = |c: [f32; 4]| [c[0], c[1], c[2]];
                let delta = m.perceptual_roughness < DELTA_ROUGHNESS;
                let layer = 0.16 * m.reflectance * m.reflectance;
                let diffuse = (1.0 - m.metallic) * (1.0 - m.specular_transmission) * (1.0 - layer);
                let base = luminance(rgb(m.base_color));
                let f0 = layer * (1.0 - m.metallic) + base * m.metallic;
                let scatter = if delta {
                    base * m.metallic + m.specular_transmission * (1.0 - m.metallic)
                } else {
                    f0
                };
                (diffuse * base + scatter).min(1.0)
            })
            .fold(0.0, f32::max)
    }
}

/// Below this perceptual roughness a lobe is a delta (`DELTA_ROUGHNESS` in bsdf.wgsl).
const DELTA_ROUGHNESS: f32 = 0.02;

/// The extracted scene and the epoch that counts its changes. Any change to meshes, materials,
/// lights or transforms increments `epoch`, which restarts progressive accumulation.
#[derive(Resource, Clone, Default, ExtractResource)]
pub struct RppmScene {
    pub data: Arc<SceneData>,
    pub epoch: u64,
}

/// Per-camera change counter: the camera's transform, projection, target size or settings.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct ViewEpoch {
    pub epoch: u64,
    key: Option<ViewKey>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct ViewKey {
    world_from_view: Mat4,
    clip_from_view: Mat4,
    target: Option<UVec2>,
}

pub struct SceneExtractionPlugin;

impl Plugin for SceneExtractionPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<RppmScene>()
            .init_resource::<ExtractionWarnings>()
            .add_systems(
                PostUpdate,
                (extract_scene, track_view_changes)
                    .after(TransformSystems::Propagate)
                    .after(VisibilitySystems::VisibilityPropagate)
                    .after(bevy::camera::CameraUpdateSystems),
            );
    }
}

/// Warnings already given, so each is logged once.
#[derive(Resource, Default)]
pub(crate) struct ExtractionWarnings {
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

#[allow(clippy::too_many_arguments)]
fn extract_scene(
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

pub(crate) fn luminance(rgb: [f32; 3]) -> f32 {
    0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]
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

fn track_view_changes(
    mut cameras: Query<(
        &mut ViewEpoch,
        &Camera,
        &GlobalTransform,
        Ref<PhotonMapping>,
    )>,
) {
    for (mut view, camera, transform, settings) in &mut cameras {
        let key = ViewKey {
            world_from_view: transform.to_matrix(),
            clip_from_view: camera.clip_from_view(),
            target: camera.physical_target_size(),
        };
        if view.key != Some(key) || settings.is_changed() {
            view.key = Some(key);
            view.epoch += 1;
        }
    }
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
