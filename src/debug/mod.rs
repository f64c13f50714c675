//! Checks by eye and by number, behind the `debug` feature: debug images that compare the deep
//! cubemap with rasterisation (the G-buffer's shading normals, and those of primary rays traced
//! through the cubemap with the same jitter), and the deep-cubemap correctness harness
//! ([`bench`]) with its hierarchy peer, and the BSDF's white furnace ([`furnace`]).

pub mod bench;
pub mod furnace;

use bevy::prelude::*;
use bevy::render::render_resource::*;
use bevy::render::{Render, RenderApp, RenderStartup, RenderSystems};

use crate::cubemap::{CubemapPipelines, DeepCubemap, trace_layout};
use crate::gbuffer::GBuffer;
use crate::importons::{dispatch_per_pixel, eye_path_layout};
use crate::settings::RppmDebugView;
use crate::shaders::RppmShaders;
use crate::stats::timing::{Stage, StageTimer};
use crate::view::ViewLayouts;

pub(crate) struct DebugPlugin;

impl Plugin for DebugPlugin {
    fn build(&self, app: &mut App) {
        app.add_plugins(bevy::render::extract_resource::ExtractResourcePlugin::<
            bench::CubemapBenchRequest,
        >::default())
            .add_plugins(bevy::render::extract_resource::ExtractResourcePlugin::<
                furnace::FurnaceRequest,
            >::default())
            .init_resource::<bench::CubemapBenchResults>()
            .init_resource::<furnace::FurnaceResults>()
            .add_systems(
                PreUpdate,
                (bench::receive_results, furnace::receive_furnace),
            );
        let (sender, receiver) = crossbeam_channel::unbounded();
        let (furnace_sender, furnace_receiver) = crossbeam_channel::unbounded();
        app.insert_resource(bench::BenchReceiver(receiver))
            .insert_resource(furnace::FurnaceReceiver(furnace_receiver));
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app
                .insert_resource(bench::BenchSender(sender))
                .insert_resource(furnace::FurnaceSender(furnace_sender))
                .add_systems(
                    RenderStartup,
                    (
                        init_debug_view_pipelines,
                        bench::init_bench_pipelines,
                        furnace::init_furnace_pipeline,
                    ),
                )
                .add_systems(
                    Render,
                    (bench::run_cubemap_bench, furnace::run_furnace)
                        .after(RenderSystems::PrepareResources)
                        .before(RenderSystems::Render),
                );
        }
    }
}

#[derive(Resource)]
pub struct DebugViewPipelines {
    gbuffer_normals: CachedComputePipelineId,
    cubemap_normals: CachedComputePipelineId,
}

impl DebugViewPipelines {
    pub fn get<'a>(
        &self,
        cache: &'a PipelineCache,
        view: RppmDebugView,
    ) -> Option<&'a ComputePipeline> {
        match view {
            RppmDebugView::None | RppmDebugView::DirectPhotons => None,
            RppmDebugView::GBufferNormals => cache.get_compute_pipeline(self.gbuffer_normals),
            RppmDebugView::CubemapNormals => cache.get_compute_pipeline(self.cubemap_normals),
        }
    }
}

fn init_debug_view_pipelines(
    mut commands: Commands,
    cache: Res<PipelineCache>,
    shaders: Res<RppmShaders>,
    layouts: Res<ViewLayouts>,
) {
    let base = vec![
        layouts.scene.clone(),
        layouts.params.clone(),
        eye_path_layout(),
    ];
    let pipeline = |entry: &'static str, layout: Vec<BindGroupLayoutDescriptor>| {
        cache.queue_compute_pipeline(ComputePipelineDescriptor {
            label: Some(format!("rppm_debug_{entry}").into()),
            layout,
            shader: shaders.debug_view.clone(),
            entry_point: Some(entry.into()),
            ..default()
        })
    };
    let mut traced = base.clone();
    traced.push(trace_layout());
    commands.insert_resource(DebugViewPipelines {
        gbuffer_normals: pipeline("gbuffer_normals", base),
        cubemap_normals: pipeline("cubemap_normals", traced),
    });
}

/// What a debug iteration records with.
pub(crate) struct DebugInputs<'a> {
    pub cache: &'a PipelineCache,
    pub cubemap_pipelines: &'a CubemapPipelines,
    pub gbuffer_pipeline: &'a RenderPipeline,
    pub view: RppmDebugView,
    /// The scene (0) and this iteration's constants (1).
    pub groups: [&'a BindGroup; 2],
    pub gbuffer: &'a GBuffer,
    pub cubemap: Option<&'a DeepCubemap>,
    /// Group 2 of the eye-path stage.
    pub own: Option<&'a BindGroup>,
    pub size: UVec2,
    pub triangles: u32,
    pub offset: u32,
}

/// One iteration of a debug image: the G-buffer's normals, or normals traced through a deep
/// cubemap built for this iteration.
pub(crate) fn encode_debug_iteration(
    encoder: &mut CommandEncoder,
    pipeline: Option<&ComputePipeline>,
    inputs: DebugInputs,
    timer: &mut StageTimer,
) {
    let Some(pipeline) = pipeline else { return };
    let groups = inputs.groups;
    let traced = inputs.view == RppmDebugView::CubemapNormals;
    let cubemap = inputs.cubemap;
    if traced {
        let Some(cubemap) = cubemap else { return };
        cubemap.encode_build(
            encoder,
            inputs.cache,
            inputs.cubemap_pipelines,
            groups[0],
            timer,
        );
    } else {
        inputs.gbuffer.encode(
            encoder,
            inputs.gbuffer_pipeline,
            groups,
            inputs.triangles,
            inputs.offset,
            timer,
        );
    }
    let Some(own) = inputs.own else {
        return;
    };
    let stage = if traced {
        Stage::CubemapTrace
    } else {
        Stage::LocalIllumination
    };
    let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
        label: Some("rppm_debug_view"),
        timestamp_writes: timer.compute_pass(stage),
    });
    pass.set_pipeline(pipeline);
    if let (true, Some(cubemap)) = (traced, cubemap) {
        pass.set_bind_group(3, &cubemap.trace_group, &[]);
    }
    dispatch_per_pixel(
        &mut pass,
        [groups[0], groups[1], own],
        inputs.offset,
        inputs.size,
    );
}
