//! The white furnace for the BSDF (`shaders/debug/furnace.wgsl`): under uniform unit
//! radiance, what a material reflects toward a direction as the splats and direct light
//! evaluate it (`bsdf_eval`), and what photons arriving from it keep on average
//! (`scatter_photon`); both on the GPU, with the scene's own albedo table.

use bevy::prelude::*;
use bevy::render::extract_resource::ExtractResource;
use bevy::render::render_resource::binding_types::{
    storage_buffer_read_only_sized, storage_buffer_sized,
};
use bevy::render::render_resource::*;
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bytemuck::{Pod, Zeroable};
use serde::Serialize;

use super::bench::empty_layout;
use crate::scene::prepare::{GgxAlbedo, storage_buffer};
use crate::scene::upload::material_texture;
use crate::scene::{GpuMaterial, ScatterPaths};
use crate::shaders::RppmShaders;
use crate::stats::readback::read_back;
use crate::view::ViewLayouts;

/// Invocations per case (`THREADS` in furnace.wgsl).
const THREADS: u32 = 256;

/// One material seen (or lit) from one direction.
#[derive(Clone, Copy, Debug)]
pub struct FurnaceCase {
    pub material: GpuMaterial,
    /// Cosine between the normal and the direction light leaves toward (eval) or arrives from
    /// (photons).
    pub cos_theta: f32,
}

/// Asks the render world to run the furnace once.
#[derive(Resource, Clone, ExtractResource)]
pub struct FurnaceRequest {
    pub cases: Vec<FurnaceCase>,
    /// Samples per case (rounded up to a multiple of 256).
    pub samples: u32,
}

/// What one case reflects (RGB): `eval` by integrating `bsdf_eval`, `photon` the mean weight
/// `scatter_photon` gives.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct FurnaceRow {
    pub eval: [f32; 3],
    pub photon: [f32; 3],
}

/// The furnace's results, in the main world, in the order of the request's cases.
#[derive(Resource, Default, Debug)]
pub struct FurnaceResults(pub Option<Vec<FurnaceRow>>);

#[derive(Resource, Deref)]
pub(super) struct FurnaceSender(pub crossbeam_channel::Sender<Vec<FurnaceRow>>);

#[derive(Resource, Deref)]
pub(super) struct FurnaceReceiver(pub crossbeam_channel::Receiver<Vec<FurnaceRow>>);

pub(super) fn receive_furnace(receiver: Res<FurnaceReceiver>, mut results: ResMut<FurnaceResults>) {
    while let Ok(rows) = receiver.try_recv() {
        results.0 = Some(rows);
    }
}

/// `Case` in furnace.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Default, Pod, Zeroable)]
struct GpuCase {
    material: GpuMaterial,
    setting: [f32; 4],
}

#[derive(Resource)]
pub(super) struct FurnacePipeline {
    layout: BindGroupLayoutDescriptor,
    pipeline: CachedComputePipelineId,
}

pub(super) fn init_furnace_pipeline(
    mut commands: Commands,
    cache: Res<PipelineCache>,
    shaders: Res<RppmShaders>,
    layouts: Res<ViewLayouts>,
) {
    let layout = BindGroupLayoutDescriptor::new(
        "rppm_furnace_layout",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                storage_buffer_read_only_sized(false, None),
                storage_buffer_sized(false, None),
            ),
        ),
    );
    let pipeline = cache.queue_compute_pipeline(ComputePipelineDescriptor {
        label: Some("rppm_furnace".into()),
        layout: vec![layouts.scene.clone(), empty_layout(), layout.clone()],
        shader: shaders.furnace.clone(),
        shader_defs: ScatterPaths::all()
            .shader_defs()
            .into_iter()
            .map(Into::into)
            .collect(),
        entry_point: Some("furnace".into()),
        ..default()
    });
    commands.insert_resource(FurnacePipeline { layout, pipeline });
}

#[expect(
    clippy::too_many_arguments,
    reason = "the render-world resources a furnace run uses"
)]
pub(super) fn run_furnace(
    request: Option<Res<FurnaceRequest>>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    cache: Res<PipelineCache>,
    layouts: Res<ViewLayouts>,
    ggx_albedo: Res<GgxAlbedo>,
    furnace: Res<FurnacePipeline>,
    sender: Res<FurnaceSender>,
    mut done: Local<bool>,
) {
    let Some(request) = request else { return };
    let Some(pipeline) = cache.get_compute_pipeline(furnace.pipeline) else {
        if let CachedPipelineState::Err(e) = cache.get_compute_pipeline_state(furnace.pipeline) {
            error!("bevy_rppm: the furnace pipeline failed to build: {e}");
        }
        return;
    };
    if *done || request.cases.is_empty() {
        return;
    }
    *done = true;
    let per_invocation = request.samples.div_ceil(THREADS).max(1);
    let cases: Vec<GpuCase> = request
        .cases
        .iter()
        .map(|c| GpuCase {
            material: c.material,
            setting: [c.cos_theta, per_invocation as f32, 0.0, 0.0],
        })
        .collect();
    // Group 0 as the stages bind it; the furnace reads only the albedo table.
    let empty = storage_buffer(&device, "rppm_furnace_empty", &[[0u32; 4]; 8]);
    let material_view = material_texture(&device, &queue, &[]);
    let scene_group = device.create_bind_group(
        "rppm_furnace_scene_group",
        &cache.get_bind_group_layout(&layouts.scene),
        &BindGroupEntries::sequential((
            empty.as_entire_binding(),
            empty.as_entire_binding(),
            &material_view,
            empty.as_entire_binding(),
            empty.as_entire_binding(),
            empty.as_entire_binding(),
            &ggx_albedo.0,
            empty.as_entire_binding(),
            empty.as_entire_binding(),
            empty.as_entire_binding(),
        )),
    );
    let empty_group = device.create_bind_group(
        "rppm_furnace_empty_group",
        &cache.get_bind_group_layout(&empty_layout()),
        &[],
    );
    let input = storage_buffer(&device, "rppm_furnace_cases", &cases);
    let output = device.create_buffer(&BufferDescriptor {
        label: Some("rppm_furnace_results"),
        size: cases.len() as u64 * 32,
        usage: BufferUsages::STORAGE | BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let group = device.create_bind_group(
        "rppm_furnace_group",
        &cache.get_bind_group_layout(&furnace.layout),
        &BindGroupEntries::sequential((input.as_entire_binding(), output.as_entire_binding())),
    );
    let mut encoder = device.create_command_encoder(&CommandEncoderDescriptor::default());
    {
        let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
            label: Some("rppm_furnace"),
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &scene_group, &[]);
        pass.set_bind_group(1, &empty_group, &[]);
        pass.set_bind_group(2, &group, &[]);
        pass.dispatch_workgroups(cases.len() as u32, 1, 1);
    }
    queue.submit([encoder.finish()]);
    let Some(bytes) = read_back(&device, &queue, &output) else {
        error!("bevy_rppm: the furnace's results could not be read back");
        return;
    };
    let values: &[[f32; 4]] = bytemuck::cast_slice(&bytes);
    let rows = values
        .chunks_exact(2)
        .map(|pair| FurnaceRow {
            eval: [pair[0][0], pair[0][1], pair[0][2]],
            photon: [pair[1][0], pair[1][1], pair[1][2]],
        })
        .collect();
    let _ = sender.send(rows);
}
