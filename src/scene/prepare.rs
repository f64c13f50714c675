//! The extracted scene on the GPU: storage buffers written, when the scene epoch moves, with
//! only what changed ([`super::upload`]), and the world-space triangles placed from them.

use std::sync::Arc;

use bevy::prelude::*;
use bevy::render::render_resource::{
    BindGroup, BindGroupEntries, BindGroupLayoutDescriptor, Buffer, BufferDescriptor,
    BufferInitDescriptor, BufferUsages, Extent3d, PipelineCache, TextureDataOrder,
    TextureDescriptor, TextureDimension, TextureFormat, TextureUsages, TextureView,
    TextureViewDescriptor,
};
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bytemuck::Pod;

use super::place::PlacePipeline;
use super::upload::{MATERIALS_ROW, Upload, material_bytes, material_rows};
use super::{GpuTriangleAttributes, Lookups, PackedTriangle, RppmScene, ScatterPaths, SceneData};
use crate::bsdf::{SIZE, ggx_albedo_table};

/// Why the scene's tables were refused (too big for the GPU), while they are; every view
/// reports it as its error.
#[derive(Resource, Clone, Debug)]
pub struct SceneRefused(pub String);

/// Scene tables as storage buffers, in the render world.
#[derive(Resource)]
pub struct SceneBuffers {
    pub epoch: u64,
    pub data: Arc<SceneData>,
    /// World-space triangles, made by the GPU from `meshes` and `instances` ([`super::place`]).
    pub triangles: Buffer,
    /// Whether the latest placement marked the triangles it moved (`MOVED_TRIANGLE`, which
    /// motion history reads): a later change that moves none places them again to clear it.
    pub moved_marks: bool,
    /// Whether the latest change may have changed the light itself (a light, an emitter, a
    /// material, the sky), not only moved objects and their shadows.
    pub relit: bool,
    /// Every mesh's triangles in its own space, in [`SceneData::meshes`] order.
    pub meshes: Buffer,
    pub instances: Buffer,
    /// The materials as texels ([`Upload::materials`]).
    pub materials: TextureView,
    pub lights: Buffer,
    pub emitters: Buffer,
    pub light_cdf: Buffer,
    /// The GGX lobe's albedo table, shared ([`GgxAlbedo`]).
    pub ggx_albedo: TextureView,
    /// Per-triangle UVs and colours, the texture table and its texels: one zeroed item each
    /// when no material is textured.
    pub attributes: Buffer,
    pub textures: Buffer,
    pub texels: Buffer,
    /// The scattering paths the materials have (made once per scene change).
    pub paths: ScatterPaths,
    /// The lookups the materials make (made once per scene change).
    pub lookups: Lookups,
    /// Whether camera paths can meet a sphere light (a point or spot light's radius) from a
    /// rough lobe they go on from (`GLOSSY`, rough glass included); once per scene change.
    pub sphere_lights: bool,
    /// Whether an emitter is more than a quad (`SceneData::has_many_faced_emitters`); once
    /// per scene change.
    pub many_faced_emitters: bool,
    /// The largest probability a photon goes on after a hit (sizes the photon store).
    pub max_scatter: f32,
    /// Bytes written to the GPU by the latest scene change: what changed, not the scene.
    pub upload_bytes: u64,
}

impl SceneBuffers {
    pub fn triangle_count(&self) -> u32 {
        self.data.triangle_count() as u32
    }

    /// Bytes of the world-space triangles (what a whole upload of the geometry would send).
    pub fn geometry_bytes(&self) -> u64 {
        self.data.triangle_count() as u64 * std::mem::size_of::<PackedTriangle>() as u64
    }

    /// (name, bytes) of every buffer held.
    pub fn memory(&self) -> [(&'static str, u64); 11] {
        [
            ("scene_triangles", self.triangles.size()),
            ("scene_meshes", self.meshes.size()),
            ("scene_instances", self.instances.size()),
            ("scene_materials", material_bytes(self.data.materials.len())),
            ("scene_lights", self.lights.size()),
            ("scene_emitters", self.emitters.size()),
            ("scene_light_cdf", self.light_cdf.size()),
            ("scene_ggx_albedo", GgxAlbedo::BYTES),
            ("scene_attributes", self.attributes.size()),
            ("scene_textures", self.textures.size()),
            ("scene_texels", self.texels.size()),
        ]
    }

    /// Group 0 of every stage: the scene tables and `shadow_views`.
    pub fn bind_group(
        &self,
        device: &RenderDevice,
        cache: &PipelineCache,
        layout: &BindGroupLayoutDescriptor,
        shadow_views: &Buffer,
    ) -> BindGroup {
        device.create_bind_group(
            "rppm_scene_group",
            &cache.get_bind_group_layout(layout),
            &BindGroupEntries::sequential((
                self.triangles.as_entire_binding(),
                shadow_views.as_entire_binding(),
                &self.materials,
                self.lights.as_entire_binding(),
                self.emitters.as_entire_binding(),
                self.light_cdf.as_entire_binding(),
                &self.ggx_albedo,
                self.attributes.as_entire_binding(),
                self.textures.as_entire_binding(),
                self.texels.as_entire_binding(),
            )),
        )
    }
}

/// A storage buffer holding `items`, or one zeroed item when there are none (bindings can't be
/// empty).
pub fn storage_buffer<T: Pod + Default>(
    device: &RenderDevice,
    label: &'static str,
    items: &[T],
) -> Buffer {
    let fallback = [T::default()];
    let items = if items.is_empty() {
        &fallback[..]
    } else {
        items
    };
    device.create_buffer_with_data(&BufferInitDescriptor {
        label: Some(label),
        contents: bytemuck::cast_slice(items),
        usage: BufferUsages::STORAGE | BufferUsages::COPY_DST,
    })
}

/// The GGX albedo table ([`crate::bsdf::ggx_albedo_table`]) on the GPU: a constant, uploaded
/// once and bound with every scene. A float texture of `SIZE` × `SIZE + 1` texels (the last
/// row the averages): llvmpipe fetches a texel for 8 lanes at once.
#[derive(Resource, Clone, Deref)]
pub struct GgxAlbedo(pub TextureView);

impl GgxAlbedo {
    pub const BYTES: u64 = (SIZE * (SIZE + 1) * 16) as u64;
}

pub(crate) fn init_ggx_albedo(
    mut commands: Commands,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
) {
    commands.insert_resource(GgxAlbedo(constant_texture(
        &device,
        &queue,
        "rppm_ggx_albedo",
        [SIZE as u32, SIZE as u32 + 1],
        TextureFormat::Rgba32Float,
        bytemuck::cast_slice(ggx_albedo_table()),
    )));
}

/// A texture of 16-byte texels (`size` texels wide and high) holding `bytes` row by row,
/// sampled by no one: the tables the shaders fetch texel by texel (llvmpipe fetches a texel
/// for 8 lanes at once, where it reads a storage buffer lane by lane).
pub fn constant_texture(
    device: &RenderDevice,
    queue: &RenderQueue,
    label: &'static str,
    size: [u32; 2],
    format: TextureFormat,
    bytes: &[u8],
) -> TextureView {
    device
        .create_texture_with_data(
            queue,
            &TextureDescriptor {
                label: Some(label),
                size: Extent3d {
                    width: size[0],
                    height: size[1],
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: TextureDimension::D2,
                format,
                usage: TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            },
            TextureDataOrder::LayerMajor,
            bytes,
        )
        .create_view(&TextureViewDescriptor::default())
}

/// Uploads what changed of the scene when its epoch moved, and places its triangles. A scene
/// too large for one storage binding is refused with one error instead of failing inside wgpu.
#[expect(
    clippy::too_many_arguments,
    reason = "the GPU's handles and the scene's"
)]
pub(crate) fn prepare_scene(
    mut commands: Commands,
    scene: Option<Res<RppmScene>>,
    buffers: Option<Res<SceneBuffers>>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    cache: Res<PipelineCache>,
    (ggx_albedo, place): (Res<GgxAlbedo>, Res<PlacePipeline>),
    mut refused_epoch: Local<Option<u64>>,
) {
    let Some(scene) = scene else { return };
    if buffers.as_ref().is_some_and(|b| b.epoch == scene.epoch)
        || *refused_epoch == Some(scene.epoch)
        || !place.ready(&cache)
    {
        return;
    }
    let data = &scene.data;
    let limit = device.limits().max_storage_buffer_binding_size;
    let local: usize = data.meshes.iter().map(|m| m.triangles.len()).sum();
    let bytes = [
        data.triangle_count().max(local) * std::mem::size_of::<PackedTriangle>(),
        data.triangle_count()
            * std::mem::size_of::<GpuTriangleAttributes>()
            * data.is_textured() as usize,
        std::mem::size_of_val(data.texels.as_slice()),
    ]
    .into_iter()
    .max()
    .unwrap_or(0) as u64;
    let rows = device.limits().max_texture_dimension_2d;
    let refusal = if material_rows(data.materials.len()) > rows {
        Some(format!(
            "the scene has {} materials, over the {} this GPU's textures hold; photon mapping \
             is paused until the scene has fewer",
            data.materials.len(),
            rows as usize * MATERIALS_ROW,
        ))
    } else if bytes > limit {
        Some(format!(
            "the scene has {} triangles and {} texels (up to {bytes} bytes in one table), over \
             this GPU's storage binding limit of {limit} bytes; photon mapping is paused until \
             the scene is smaller",
            data.triangle_count(),
            data.texels.len()
        ))
    } else {
        None
    };
    if let Some(why) = refusal {
        error!("bevy_rppm: {why}");
        *refused_epoch = Some(scene.epoch);
        commands.remove_resource::<SceneBuffers>();
        commands.insert_resource(SceneRefused(why));
        return;
    }
    commands.remove_resource::<SceneRefused>();
    let last = buffers.as_deref();
    let mut upload = Upload {
        device: &device,
        queue: &queue,
        bytes: 0,
    };
    let (meshes, meshes_changed) = upload.meshes(last, data);
    let (instances, instances_changed) = upload.diff(
        last.map(|l| (&l.instances, l.data.instances.as_slice())),
        &data.instances,
        "rppm_instances",
    );
    let count = data.triangle_count();
    let triangles = match last {
        Some(l) if l.data.triangle_count() == count => l.triangles.clone(),
        _ => device.create_buffer(&BufferDescriptor {
            label: Some("rppm_triangles"),
            size: (count.max(1) * std::mem::size_of::<PackedTriangle>()) as u64,
            usage: BufferUsages::STORAGE,
            mapped_at_creation: false,
        }),
    };
    let placed = last.is_some_and(|l| l.triangles.id() == triangles.id());
    let moves = meshes_changed || instances_changed || !placed;
    let clears = placed && last.is_some_and(|l| l.moved_marks);
    if count > 0 && (moves || clears) {
        let buffers = [&meshes, &instances, &triangles];
        // A new buffer's triangles are not marked moved, or a still scene's history would
        // read every surface as moving until its first change (which then dropped its
        // silhouettes' samples).
        let new = !placed;
        place.place(&device, &queue, &cache, buffers, count as u32, new);
    }
    let attributes = upload.attributes(last, data);
    let materials = upload.materials(last, data);
    let lights = upload.table(last, data, |d| &d.lights, |b| &b.lights, "rppm_lights");
    let emitters = upload.table(
        last,
        data,
        |d| &d.emitters,
        |b| &b.emitters,
        "rppm_emitters",
    );
    let light_cdf = upload.table(
        last,
        data,
        |d| &d.light_cdf,
        |b| &b.light_cdf,
        "rppm_light_cdf",
    );
    let textures = upload.table(
        last,
        data,
        |d| &d.textures,
        |b| &b.textures,
        "rppm_textures",
    );
    // A change that kept the textures (a moved object) keeps their upload.
    let texels = match last {
        Some(b) if Arc::ptr_eq(&b.data.texels, &data.texels) => b.texels.clone(),
        _ => upload.new_buffer("rppm_texels", data.texels.as_slice()),
    };
    let upload_bytes = upload.bytes;
    let paths = data.scatter_paths();
    commands.insert_resource(SceneBuffers {
        epoch: scene.epoch,
        data: data.clone(),
        paths,
        lookups: data.lookups(),
        sphere_lights: paths.contains(ScatterPaths::GLOSSY) && data.has_sphere_lights(),
        many_faced_emitters: data.has_many_faced_emitters(),
        max_scatter: data.max_scatter_probability(),
        triangles,
        moved_marks: count > 0 && moves && placed,
        // A moved emissive object moves its light too.
        relit: last.is_none_or(|l| !l.data.same_light(data))
            || (moves && !data.emitters.is_empty()),
        meshes,
        instances,
        materials,
        lights,
        emitters,
        light_cdf,
        ggx_albedo: ggx_albedo.0.clone(),
        attributes,
        textures,
        texels,
        upload_bytes,
    });
}
