//! The extracted scene on the GPU: storage buffers re-uploaded only when the scene epoch moves.

use std::sync::Arc;

use bevy::prelude::*;
use bevy::render::render_resource::{
    BindGroup, BindGroupEntries, BindGroupLayoutDescriptor, Buffer, BufferInitDescriptor,
    BufferUsages, PipelineCache,
};
use bevy::render::renderer::RenderDevice;
use bytemuck::Pod;

use super::{GpuTriangle, PackedTriangle, RppmScene, ScatterPaths, SceneData};
use crate::bsdf::ggx_albedo_table;

/// Why the scene's tables were refused (too big for the GPU), while they are; every view
/// reports it as its error.
#[derive(Resource, Clone, Debug)]
pub struct SceneRefused(pub String);

/// Scene tables as storage buffers, in the render world.
#[derive(Resource)]
pub struct SceneBuffers {
    pub epoch: u64,
    pub data: Arc<SceneData>,
    pub triangles: Buffer,
    pub materials: Buffer,
    pub lights: Buffer,
    pub emitters: Buffer,
    pub light_cdf: Buffer,
    /// The GGX lobe's albedo table, shared ([`GgxAlbedoBuffer`]).
    pub ggx_albedo: Buffer,
    /// Per-triangle UVs and colours, the texture table and its texels: one zeroed item each
    /// when no material is textured.
    pub attributes: Buffer,
    pub textures: Buffer,
    pub texels: Buffer,
    /// The scattering paths the materials have (made once per scene change).
    pub paths: ScatterPaths,
    /// The largest probability a photon goes on after a hit (sizes the photon store).
    pub max_scatter: f32,
}

impl SceneBuffers {
    pub fn triangle_count(&self) -> u32 {
        self.data.triangles.len() as u32
    }

    /// (name, bytes) of every buffer held.
    pub fn memory(&self) -> [(&'static str, u64); 9] {
        [
            ("scene_triangles", self.triangles.size()),
            ("scene_materials", self.materials.size()),
            ("scene_lights", self.lights.size()),
            ("scene_emitters", self.emitters.size()),
            ("scene_light_cdf", self.light_cdf.size()),
            ("scene_ggx_albedo", self.ggx_albedo.size()),
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
                self.materials.as_entire_binding(),
                self.lights.as_entire_binding(),
                self.emitters.as_entire_binding(),
                self.light_cdf.as_entire_binding(),
                self.ggx_albedo.as_entire_binding(),
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
/// once and bound with every scene.
#[derive(Resource, Clone, Deref)]
pub struct GgxAlbedoBuffer(pub Buffer);

pub(crate) fn init_ggx_albedo(mut commands: Commands, device: Res<RenderDevice>) {
    commands.insert_resource(GgxAlbedoBuffer(storage_buffer(
        &device,
        "rppm_ggx_albedo",
        ggx_albedo_table(),
    )));
}

/// Uploads the scene when its epoch changed. A scene too large for one storage binding is
/// refused with one error instead of failing inside wgpu.
pub(crate) fn prepare_scene(
    mut commands: Commands,
    scene: Option<Res<RppmScene>>,
    buffers: Option<Res<SceneBuffers>>,
    device: Res<RenderDevice>,
    ggx_albedo: Res<GgxAlbedoBuffer>,
    mut refused_epoch: Local<Option<u64>>,
) {
    let Some(scene) = scene else { return };
    if buffers.as_ref().is_some_and(|b| b.epoch == scene.epoch)
        || *refused_epoch == Some(scene.epoch)
    {
        return;
    }
    let data = &scene.data;
    let limit = device.limits().max_storage_buffer_binding_size;
    let bytes = [
        data.triangles.len() * std::mem::size_of::<PackedTriangle>(),
        std::mem::size_of_val(data.attributes.as_slice()),
        std::mem::size_of_val(data.texels.as_slice()),
    ]
    .into_iter()
    .max()
    .unwrap_or(0) as u64;
    if bytes > limit {
        let why = format!(
            "the scene has {} triangles and {} texels (up to {bytes} bytes in one table), over \
             this GPU's storage binding limit of {limit} bytes; photon mapping is paused until \
             the scene is smaller",
            data.triangles.len(),
            data.texels.len()
        );
        error!("bevy_rppm: {why}");
        *refused_epoch = Some(scene.epoch);
        commands.remove_resource::<SceneBuffers>();
        commands.insert_resource(SceneRefused(why));
        return;
    }
    commands.remove_resource::<SceneRefused>();
    commands.insert_resource(SceneBuffers {
        epoch: scene.epoch,
        data: data.clone(),
        paths: data.scatter_paths(),
        max_scatter: data.max_scatter_probability(),
        triangles: storage_buffer(
            &device,
            "rppm_triangles",
            &packed_triangles(&data.triangles),
        ),
        materials: storage_buffer(&device, "rppm_materials", &data.materials),
        lights: storage_buffer(&device, "rppm_lights", &data.lights),
        emitters: storage_buffer(&device, "rppm_emitters", &data.emitters),
        light_cdf: storage_buffer(&device, "rppm_light_cdf", &data.light_cdf),
        ggx_albedo: ggx_albedo.0.clone(),
        attributes: storage_buffer(&device, "rppm_triangle_attributes", &data.attributes),
        textures: storage_buffer(&device, "rppm_textures", &data.textures),
        // A change that kept the textures (a moved object) keeps their upload.
        texels: match &buffers {
            Some(b) if Arc::ptr_eq(&b.data.texels, &data.texels) => b.texels.clone(),
            _ => storage_buffer(&device, "rppm_texels", &data.texels),
        },
    });
}

/// The triangles as the GPU stores them.
fn packed_triangles(triangles: &[GpuTriangle]) -> Vec<PackedTriangle> {
    triangles.iter().map(PackedTriangle::from).collect()
}
