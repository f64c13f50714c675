//! Indirect splatting: each importon visits the deep-cubemap tiles its own radius reaches
//! and adds the photons the photon map holds there (a run of the map per row of tiles;
//! `shaders/indirect_splat/indirect_splat.wgsl`). The gather is dispatched indirectly: the
//! eye-path stage sets its workgroup count only when it makes an importon, so an iteration
//! whose glass is off screen runs no workgroup.

#[cfg(test)]
pub(crate) mod disc;

use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{
    storage_buffer_read_only_sized, storage_buffer_sized,
};
use bevy::render::render_resource::*;
use bevy::render::renderer::RenderDevice;
use bevy::render::{RenderApp, RenderStartup};

use crate::cubemap::{TracingGroups, tracing_pipeline};
use crate::importons::{EyePaths, GATHER_DISPATCH};
use crate::photons::PhotonStore;
use crate::scene::{Lookups, ScatterPaths, material_defs};
use crate::shaders::RppmShaders;
use crate::stats::timing::{Stage, StageTimer};
use crate::view::ViewLayouts;

pub(crate) struct IndirectSplatPlugin;

impl Plugin for IndirectSplatPlugin {
    fn build(&self, app: &mut App) {
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app
                .init_resource::<SpecializedComputePipelines<IndirectSplatPipeline>>()
                .add_systems(RenderStartup, init_indirect_splat_pipeline);
        }
    }
}

/// The indirect-splat stage, specialized by [`IndirectSplatKey`]. Each variant is queued the
/// first time a view makes importons.
#[derive(Resource)]
pub struct IndirectSplatPipeline {
    /// 0 the photon map, 1 its tiles' starts, 2 importons, 3 gathered radiance per
    /// importon, 4 the importons' kernel statistics.
    pub layout: BindGroupLayoutDescriptor,
    descriptor: ComputePipelineDescriptor,
}

/// Which indirect-splat variant a view runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct IndirectSplatKey {
    /// The scene's material lookups.
    pub lookups: Lookups,
    /// The scene's extra BSDF layers ([`ScatterPaths::LAYERS`]).
    pub layers: ScatterPaths,
    /// Rays (the importons' discs checked for corners) walk the scene's BVH.
    pub bvh: bool,
    /// The scene has glass or water, past which a disc's photons are left out (`GLASS`).
    pub glass: bool,
    /// Each pixel's importon kernels shrink where they blur (`ADAPTIVE_KERNEL`, as the direct
    /// splat's: `ResourceKey::adaptive_kernel`).
    pub adaptive_kernel: bool,
}

impl SpecializedComputePipeline for IndirectSplatPipeline {
    type Key = IndirectSplatKey;

    fn specialize(&self, key: IndirectSplatKey) -> ComputePipelineDescriptor {
        ComputePipelineDescriptor {
            shader_defs: {
                let mut defs = material_defs(key.lookups, key.layers);
                if key.bvh {
                    defs.push("BVH".into());
                }
                if key.glass {
                    defs.push("GLASS".into());
                }
                if key.adaptive_kernel {
                    defs.push("ADAPTIVE_KERNEL".into());
                }
                defs
            },
            entry_point: Some("gather".into()),
            ..self.descriptor.clone()
        }
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
            (read(), read(), read(), write(), write()),
        ),
    );
    let descriptor = tracing_pipeline(
        "rppm_indirect_splat",
        &layouts,
        &layout,
        &shaders.indirect_splat,
    );
    commands.insert_resource(IndirectSplatPipeline { layout, descriptor });
}

/// The group binding one camera's photons to its importons; `kernel_stats` is a
/// [`crate::splat::kernel_stats`] buffer of the view's size where kernels adapt.
pub fn bind_group(
    device: &RenderDevice,
    cache: &PipelineCache,
    pipeline: &IndirectSplatPipeline,
    store: &PhotonStore,
    eye_paths: &EyePaths,
    kernel_stats: &Buffer,
) -> BindGroup {
    device.create_bind_group(
        "rppm_indirect_splat_group",
        &cache.get_bind_group_layout(&pipeline.layout),
        &BindGroupEntries::sequential((
            store.map.photons.as_entire_binding(),
            store.map.tile_starts.as_entire_binding(),
            eye_paths.importons.as_entire_binding(),
            eye_paths.radiance.as_entire_binding(),
            kernel_stats.as_entire_binding(),
        )),
    )
}

/// Gathers the stored photons at the importons.
pub fn encode(
    encoder: &mut CommandEncoder,
    gather: &ComputePipeline,
    groups: &TracingGroups,
    own: &BindGroup,
    eye_paths: &EyePaths,
    timer: &mut StageTimer,
) {
    let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
        label: Some("rppm_indirect_splat"),
        timestamp_writes: timer.compute_pass(Stage::IndirectSplat),
    });
    groups.bind(&mut pass, gather, own);
    pass.dispatch_workgroups_indirect(&eye_paths.stats, GATHER_DISPATCH);
}
