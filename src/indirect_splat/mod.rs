//! Indirect splatting: the stored photons are listed in the deep-cubemap tiles that hold them
//! (`bin`), then each importon visits the tiles its own radius reaches and adds the photons
//! near it (`gather`; `shaders/indirect_splat/indirect_splat.wgsl`). Both are dispatched
//! indirectly: the eye-path stage sets their workgroup counts only when it makes an importon,
//! so an iteration whose glass is off screen runs no workgroup.

use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{
    storage_buffer_read_only_sized, storage_buffer_sized,
};
use bevy::render::render_resource::*;
use bevy::render::renderer::RenderDevice;
use bevy::render::{RenderApp, RenderStartup};

use crate::cubemap::{TracingGroups, tracing_pipeline};
use crate::importons::{BIN_DISPATCH, EyePaths, GATHER_DISPATCH};
use crate::photons::PhotonStore;
use crate::scene::texture_defs;
use crate::shaders::RppmShaders;
use crate::stats::timing::{Stage, StageTimer};
use crate::view::ViewLayouts;

pub(crate) struct IndirectSplatPlugin;

impl Plugin for IndirectSplatPlugin {
    fn build(&self, app: &mut App) {
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app.add_systems(RenderStartup, init_indirect_splat_pipeline);
        }
    }
}

/// The indirect-splat stage: binning photons, and gathering them, specialized by whether the
/// scene is textured (`TEXTURED`). Each is queued the first time a view makes importons.
#[derive(Resource)]
pub struct IndirectSplatPipeline {
    /// 0 photons, 1 photon count, 2 importons, 3 the tiles' photon lists' heads, 4 gathered
    /// radiance per importon.
    pub layout: BindGroupLayoutDescriptor,
    descriptor: ComputePipelineDescriptor,
    bin: Option<CachedComputePipelineId>,
    /// Untextured, textured.
    gather: [Option<CachedComputePipelineId>; 2],
}

impl IndirectSplatPipeline {
    /// The binning and gathering pipelines, queued now if they never were.
    pub fn ids(&mut self, cache: &PipelineCache, textured: bool) -> [CachedComputePipelineId; 2] {
        let descriptor = &self.descriptor;
        let bin = *self.bin.get_or_insert_with(|| {
            cache.queue_compute_pipeline(ComputePipelineDescriptor {
                entry_point: Some("bin".into()),
                ..descriptor.clone()
            })
        });
        let gather = *self.gather[textured as usize].get_or_insert_with(|| {
            cache.queue_compute_pipeline(ComputePipelineDescriptor {
                shader_defs: texture_defs(textured),
                entry_point: Some("gather".into()),
                ..descriptor.clone()
            })
        });
        [bin, gather]
    }
}

fn init_indirect_splat_pipeline(
    mut commands: Commands,
    shaders: Res<RppmShaders>,
    layouts: Res<ViewLayouts>,
) {
    let read = || storage_buffer_read_only_sized(false, None);
    let write = || storage_buffer_sized(false, None);
    let layout = BindGroupLayoutDescriptor::new(
        "rppm_indirect_splat_layout",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (write(), read(), read(), write(), write()),
        ),
    );
    let descriptor = tracing_pipeline(
        "rppm_indirect_splat",
        &layouts,
        &layout,
        &shaders.indirect_splat,
    );
    commands.insert_resource(IndirectSplatPipeline {
        layout,
        descriptor,
        bin: None,
        gather: [None; 2],
    });
}

/// The group binding one camera's photons to its importons.
pub fn bind_group(
    device: &RenderDevice,
    cache: &PipelineCache,
    pipeline: &IndirectSplatPipeline,
    store: &PhotonStore,
    eye_paths: &EyePaths,
) -> BindGroup {
    device.create_bind_group(
        "rppm_indirect_splat_group",
        &cache.get_bind_group_layout(&pipeline.layout),
        &BindGroupEntries::sequential((
            store.photons.as_entire_binding(),
            store.count.as_entire_binding(),
            eye_paths.importons.as_entire_binding(),
            eye_paths.photon_heads.as_entire_binding(),
            eye_paths.radiance.as_entire_binding(),
        )),
    )
}

/// Bins the stored photons, then gathers them at the importons.
pub fn encode(
    encoder: &mut CommandEncoder,
    [bin, gather]: [&ComputePipeline; 2],
    groups: &TracingGroups,
    own: &BindGroup,
    eye_paths: &EyePaths,
    timer: &mut StageTimer,
) {
    let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
        label: Some("rppm_indirect_splat"),
        timestamp_writes: timer.compute_pass(Stage::IndirectSplat),
    });
    groups.bind(&mut pass, bin, own);
    pass.dispatch_workgroups_indirect(&eye_paths.stats, BIN_DISPATCH);
    pass.set_pipeline(gather);
    pass.dispatch_workgroups_indirect(&eye_paths.stats, GATHER_DISPATCH);
}
