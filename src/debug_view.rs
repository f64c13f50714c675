//! Debug images that compare the deep cubemap with rasterisation: the G-buffer's shading
//! normals, and those of primary rays traced through DIRT with the same jitter.

use bevy::prelude::*;
use bevy::render::render_resource::*;

use crate::cubemap::CubemapPipelines;
use crate::pipelines::{RppmPipelines, RppmShaders};
use crate::settings::RppmDebugView;

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

pub(crate) fn init_debug_view_pipelines(
    mut commands: Commands,
    cache: Res<PipelineCache>,
    shaders: Res<RppmShaders>,
    rppm: Res<RppmPipelines>,
    cubemap: Res<CubemapPipelines>,
) {
    let base = vec![
        rppm.scene_layout.clone(),
        rppm.params_layout.clone(),
        rppm.local_layout.clone(),
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
    traced.push(cubemap.trace_layout.clone());
    commands.insert_resource(DebugViewPipelines {
        gbuffer_normals: pipeline("gbuffer_normals", base),
        cubemap_normals: pipeline("cubemap_normals", traced),
    });
}
