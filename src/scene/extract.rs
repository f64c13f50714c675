//! Every visible `Mesh3d` + `StandardMaterial` to world-space triangles, materials, lights and
//! emitters in flat tables, rebuilt only when something in the scene changed.

use std::sync::Arc;

use bevy::ecs::entity::EntityHashSet;
use bevy::image::ImageSamplerDescriptor;
use bevy::mesh::UvChannel;
use bevy::platform::collections::{HashMap, HashSet};
use bevy::prelude::*;

use super::material::material_to_gpu;
use super::textures::{
    GpuTexture, MAX_TEXTURE_SIZE, NO_TEXTURE, PackedTexture, TEXEL_BUDGET, TextureSampler,
};
use super::{
    GpuInstance, MaterialFlags, RppmScene, SceneData, SceneMesh, deform, emitters, lights, mesh,
};
use bevy::math::Affine3A;

/// Warnings already given, so each is logged once.
#[derive(Resource, Default)]
pub(super) struct ExtractionWarnings {
    meshes: HashSet<AssetId<Mesh>>,
    entities: EntityHashSet,
    images: HashSet<AssetId<Image>>,
}

/// A scene's texture table and texels, by the images in it (in slot order).
type PackedTable = (Vec<AssetId<Image>>, Vec<GpuTexture>, Arc<Vec<u32>>);

/// Images packed for the tracing stages ([`PackedTexture`]), kept across extractions so a
/// scene change does not downsample them again.
#[derive(Resource)]
pub(super) struct TextureCache {
    /// The `ImagePlugin`'s sampler, for images that name none.
    default_sampler: ImageSamplerDescriptor,
    packed: HashMap<AssetId<Image>, Arc<PackedTexture>>,
    /// The images the last extraction asked for, loaded or not: an event on one of them
    /// extracts again (an image still loading, an edited texture).
    referenced: HashSet<AssetId<Image>>,
    /// The last scene's texture table and texels, by the images in it: a scene change that
    /// keeps them (a moved object) shares them instead of copying and uploading them again.
    table: Option<PackedTable>,
}

impl TextureCache {
    /// Empty, with `app`'s `ImagePlugin` sampler (Bevy's linear one without the plugin); made
    /// in `Plugin::finish`, after every plugin's build, whatever their order.
    pub(super) fn for_app(app: &App) -> Self {
        let default_sampler = app
            .get_added_plugins::<bevy::image::ImagePlugin>()
            .first()
            .map_or_else(ImageSamplerDescriptor::linear, |p| {
                p.default_sampler.clone()
            });
        Self {
            default_sampler,
            packed: HashMap::default(),
            referenced: HashSet::default(),
            table: None,
        }
    }
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

/// The assets a scene is made of.
type SceneAssets<'w> = (
    Res<'w, Assets<Mesh>>,
    Res<'w, Assets<StandardMaterial>>,
    Res<'w, Assets<Image>>,
);

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
    mut image_events: MessageReader<AssetEvent<Image>>,
    mut lights_q: lights::LightQueries,
    mut deformers: deform::Deformers,
    assets: SceneAssets,
    mut warnings: ResMut<ExtractionWarnings>,
    (mut cache, mut meshes_cache): (ResMut<TextureCache>, ResMut<mesh::MeshCache>),
    mut scene: ResMut<RppmScene>,
) {
    let (mesh_assets, material_assets, image_assets) = assets;
    let mut image_changed = false;
    for event in image_events.read() {
        let id = match *event {
            AssetEvent::Added { id }
            | AssetEvent::Modified { id }
            | AssetEvent::Removed { id }
            | AssetEvent::LoadedWithDependencies { id } => id,
            AssetEvent::Unused { .. } => continue,
        };
        if cache.referenced.contains(&id) {
            cache.packed.remove(&id);
            cache.table = None;
            image_changed = true;
        }
    }
    let mut mesh_changed = false;
    for event in mesh_events.read() {
        match *event {
            AssetEvent::Unused { .. } => {}
            AssetEvent::Added { id }
            | AssetEvent::Modified { id }
            | AssetEvent::Removed { id }
            | AssetEvent::LoadedWithDependencies { id } => {
                meshes_cache.forget(id);
                mesh_changed = true;
            }
        }
    }
    let dirty = !changed_meshes.is_empty()
        || !changed_lights.is_empty()
        || removed_meshes.read().count() > 0
        || removed_point.read().count() + removed_spot.read().count() + removed_dir.read().count()
            > 0
        || mesh_changed
        || material_events.read().count() > 0
        || image_changed
        || lights_q.sky_changed()
        || deformers.changed();
    if !dirty {
        return;
    }
    let started = std::time::Instant::now();
    let mut data = SceneData::default();
    let mut material_index: HashMap<AssetId<StandardMaterial>, u32> = HashMap::default();
    let mut mesh_index: HashMap<*const SceneMesh, u32> = HashMap::default();
    let mut textures = TextureTable::default();
    let mut seen = EntityHashSet::default();
    let mut bounds: Option<(Vec3, Vec3)> = None;
    // Each instance's world bounds (None: unknown), for the emitters' receivers.
    let mut instance_bounds = Vec::new();
    cache.referenced.clear();
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
        let joints = match deformers.skin(entity) {
            deform::Skin::Posed(joints) => Some(joints),
            deform::Skin::None => None,
            deform::Skin::Loading => continue,
            deform::Skin::Broken(reason) => {
                if warnings.entities.insert(entity) {
                    warn!("bevy_rppm: skinned entity {entity} is left out: {reason}");
                }
                continue;
            }
        };
        // A skin is posed in world space; anything else is placed by its transform.
        let place = if joints.is_some() {
            Affine3A::IDENTITY
        } else {
            affine
        };
        let Some(mut instance) = GpuInstance::new(place, 0, 0) else {
            if warnings.entities.insert(entity) {
                warn!(
                    "bevy_rppm: entity {entity} has a non-finite or flattening transform; it is \
                     left out"
                );
            }
            continue;
        };
        let weights = deformers.morph_weights(entity);
        let uvs = reads_second_uvs(material);
        let local =
            match meshes_cache.mesh(entity, &mesh3d.0, mesh, joints.as_deref(), weights, uvs) {
                Ok(local) => local,
                Err(reason) => {
                    if warnings.meshes.insert(mesh3d.0.id()) {
                        warn!(
                            "bevy_rppm: mesh {:?} of entity {entity} is left out: {reason}",
                            mesh3d.0.id()
                        );
                    }
                    continue;
                }
            };
        if local.triangles.is_empty() {
            continue;
        }
        seen.insert(entity);
        let next = data.materials.len() as u32;
        let index = *material_index.entry(material3d.0.id()).or_insert(next);
        if index == next {
            let mut slot = |image: &Option<Handle<Image>>| {
                textures.slot(image.as_ref(), &image_assets, &mut cache, &mut warnings)
            };
            let slots = [
                slot(&material.base_color_texture),
                slot(&material.metallic_roughness_texture),
                slot(&material.emissive_texture),
                slot(&material.normal_map_texture),
            ];
            data.materials.push(material_to_gpu(material, slots));
        }
        if local.colored {
            data.materials[index as usize].flags |= MaterialFlags::TEXTURED.bits();
        }
        let next = data.meshes.len() as u32;
        instance.mesh = *mesh_index.entry(Arc::as_ptr(&local)).or_insert(next);
        if instance.mesh == next {
            data.meshes.push(local.clone());
        }
        instance.material = index;
        instance.first_world = data.triangle_count() as u32;
        instance.triangle_count = local.triangles.len() as u32;
        let placed = meshes_cache.bounds(entity, &instance, &local);
        if let Some((lo, hi)) = placed {
            bounds = Some(bounds.map_or((lo, hi), |(a, b)| (a.min(lo), b.max(hi))));
        }
        instance_bounds.push(placed);
        data.instances.push(instance);
    }
    meshes_cache.keep(&seen);
    let mut first_local = Vec::with_capacity(data.meshes.len());
    let mut sum = 0u32;
    for m in &data.meshes {
        first_local.push(sum);
        sum += m.triangles.len() as u32;
    }
    for i in &mut data.instances {
        i.first_local = first_local[i.mesh as usize];
    }
    data.bounds = bounds.unwrap_or((Vec3::ZERO, Vec3::ZERO));
    lights::collect_lights(&lights_q, &mut data);
    emitters::collect_emitters(&mut data, &textures.packed, &instance_bounds);
    textures.write(&mut data, &mut cache);
    data.light_cdf = emitters::cdf(
        data.lights
            .iter()
            .map(|l| l.radiance[3])
            .chain(data.emitters.iter().map(|e| e.power))
            .chain((data.sky[3] > 0.0).then_some(data.sky[3])),
    );
    scene.extract_ms = started.elapsed().as_secs_f64() * 1e3;
    if !scene.data.same_as(&data) {
        scene.data = Arc::new(data);
        scene.epoch += 1;
    }
}

/// Whether a material's textures read the second UV set (Bevy's `UvChannel::Uv1`): the base
/// colour texture's set, or the first other texture's. Triangles hold one set, so textures
/// that read the other are read through it (warned once).
fn reads_second_uvs(material: &StandardMaterial) -> bool {
    let second: Vec<bool> = [
        (&material.base_color_texture, &material.base_color_channel),
        (
            &material.metallic_roughness_texture,
            &material.metallic_roughness_channel,
        ),
        (&material.emissive_texture, &material.emissive_channel),
        (&material.normal_map_texture, &material.normal_map_channel),
    ]
    .into_iter()
    .filter_map(|(texture, channel)| texture.is_some().then_some(*channel == UvChannel::Uv1))
    .collect();
    let first = second.first().copied().unwrap_or(false);
    if second.iter().any(|&s| s != first) {
        warn_once!(
            "bevy_rppm: a material's textures read both UV sets; bevy_rppm reads them all \
             through the base colour texture's"
        );
    }
    first
}

/// The textures of one extraction: each image once, in order of first use.
#[derive(Default)]
struct TextureTable {
    index: HashMap<AssetId<Image>, u32>,
    ids: Vec<AssetId<Image>>,
    packed: Vec<Arc<PackedTexture>>,
}

impl TextureTable {
    /// The slot of `image` in this scene's table, or [`NO_TEXTURE`] when there is none or it
    /// cannot be used (not loaded yet: its load extracts again; unreadable: warned once).
    fn slot(
        &mut self,
        image: Option<&Handle<Image>>,
        images: &Assets<Image>,
        cache: &mut TextureCache,
        warnings: &mut ExtractionWarnings,
    ) -> u32 {
        let Some(image) = image else {
            return NO_TEXTURE;
        };
        let id = image.id();
        cache.referenced.insert(id);
        if let Some(&slot) = self.index.get(&id) {
            return slot;
        }
        let packed = match cache.packed.get(&id) {
            Some(packed) => packed.clone(),
            None => {
                let Some(source) = images.get(id) else {
                    return NO_TEXTURE;
                };
                match PackedTexture::from_image(source, MAX_TEXTURE_SIZE) {
                    Ok(mut packed) => {
                        packed.sampler = TextureSampler::of(source, &cache.default_sampler);
                        let packed = Arc::new(packed);
                        cache.packed.insert(id, packed.clone());
                        packed
                    }
                    Err(reason) => {
                        if warnings.images.insert(id) {
                            warn!("bevy_rppm: texture {id:?} is left out: {reason}");
                        }
                        return NO_TEXTURE;
                    }
                }
            }
        };
        let slot = self.packed.len() as u32;
        self.index.insert(id, slot);
        self.ids.push(id);
        self.packed.push(packed);
        slot
    }

    /// Fills the scene's texture table and texels, leaving out the largest levels of the
    /// largest textures while the whole exceeds [`TEXEL_BUDGET`]; the last scene's when it
    /// used the same images.
    fn write(&self, data: &mut SceneData, cache: &mut TextureCache) {
        if let Some((ids, table, texels)) = &cache.table
            && *ids == self.ids
        {
            data.textures = table.clone();
            data.texels = texels.clone();
            return;
        }
        let mut skipped = vec![0u32; self.packed.len()];
        let bytes = |skipped: &[u32]| -> u64 {
            self.packed
                .iter()
                .zip(skipped)
                .map(|(t, &s)| 4 * (t.texels.len() - t.level_start(s)) as u64)
                .sum()
        };
        while bytes(&skipped) > TEXEL_BUDGET {
            let Some((largest, _)) = self
                .packed
                .iter()
                .enumerate()
                .filter(|(i, t)| skipped[*i] + 1 < t.levels())
                .max_by_key(|(i, t)| (t.width.max(t.height) >> skipped[*i], *i))
            else {
                break;
            };
            skipped[largest] += 1;
        }
        let mut texels = Vec::new();
        for (t, &s) in self.packed.iter().zip(&skipped) {
            data.textures.push(t.gpu(texels.len() as u32, s));
            texels.extend_from_slice(&t.texels[t.level_start(s)..]);
        }
        data.texels = Arc::new(texels);
        cache.table = Some((self.ids.clone(), data.textures.clone(), data.texels.clone()));
    }
}
