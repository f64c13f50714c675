//! The render-graph system: records this frame's PPM iterations of one view, then its output.
//! It reads the view's state; only the stage timer is written while recording.

use bevy::prelude::*;
use bevy::render::render_resource::*;
use bevy::render::renderer::{RenderContext, RenderDevice, RenderQueue, ViewQuery};
use bevy::render::view::ViewTarget;

use super::state::{RppmViewState, ViewTimer};
use crate::cubemap::{CubemapPipelines, TracingGroups};
use crate::photons::PhotonPasses;
use crate::scene::SceneBuffers;
use crate::settings::RppmDebugView;
use crate::shadows::{ShadowPipeline, render_layers};
use crate::stats::profile::{Checkpoints, mark};
use crate::stats::timing::{FrameWork, Stage, StageTimer};
use crate::view::PARAMS_STRIDE;

/// Pipelines the node records with, all compiled.
struct NodePipelines<'a> {
    cache: &'a PipelineCache,
    device: &'a RenderDevice,
    cubemap: &'a CubemapPipelines,
    shadow: &'a RenderPipeline,
    gbuffer: &'a RenderPipeline,
    eye_paths: &'a ComputePipeline,
    photon: Option<PhotonPasses<'a>>,
    splat: Option<&'a ComputePipeline>,
    indirect_splat: Option<&'a ComputePipeline>,
    accumulate: &'a ComputePipeline,
    outliers: Option<[&'a ComputePipeline; 2]>,
}

/// This frame's PPM iterations of the view, then the view output.
pub(crate) fn rppm_node(
    view: ViewQuery<(&ViewTarget, &RppmViewState, &mut ViewTimer)>,
    scene: Option<Res<SceneBuffers>>,
    shadow: Res<ShadowPipeline>,
    cubemap_pipelines: Res<CubemapPipelines>,
    #[cfg(feature = "debug")] debug_pipelines: Res<crate::debug::DebugViewPipelines>,
    (cache, device, queue): (Res<PipelineCache>, Res<RenderDevice>, Res<RenderQueue>),
    mut ctx: RenderContext,
) {
    let (view_target, state, mut timer) = view.into_inner();
    let (Some(scene), Some(stages)) = (scene, state.stages) else {
        return;
    };
    let (Some(shadow), Some(gbuffer), Some(eye_paths), Some(accumulate)) = (
        cache.get_render_pipeline(shadow.0),
        cache.get_render_pipeline(stages.gbuffer),
        cache.get_compute_pipeline(stages.eye_paths),
        cache.get_compute_pipeline(stages.accumulate),
    ) else {
        return;
    };
    let node = NodePipelines {
        cache: &cache,
        device: &device,
        cubemap: &cubemap_pipelines,
        shadow,
        gbuffer,
        eye_paths,
        photon: photon_passes(&cache, stages.trace, stages.sort),
        splat: stages.splat.and_then(|id| cache.get_compute_pipeline(id)),
        indirect_splat: stages
            .indirect_splat
            .and_then(|id| cache.get_compute_pipeline(id)),
        accumulate,
        outliers: stages.outliers.and_then(|[bound, spread]| {
            Some([
                cache.get_compute_pipeline(bound)?,
                cache.get_compute_pipeline(spread)?,
            ])
        }),
    };
    let ViewTimer(timer, wall) = &mut *timer;
    let encoder = ctx.command_encoder();
    // Profiling submits each stage itself: only ours, which need nothing Bevy recorded
    // earlier this frame (the output, which draws into Bevy's view, stays in the frame).
    let mut checkpoints = state
        .profile
        .then(|| Checkpoints::start(&device, &queue, wall, encoder));
    timer.begin_frame(FrameWork {
        iterations: state.frame.1,
        photons: state.photons,
    });
    let (_, count) = state.frame;
    if state.reprojects {
        state.estimate.encode_keep_previous(encoder);
    }
    if state.kernels_restart {
        encoder.clear_buffer(&state.importon_kernel_stats, 0, None);
    }
    for slot in 0..count {
        let offset = (slot as u64 * PARAMS_STRIDE) as u32;
        if matches!(
            state.debug_view,
            RppmDebugView::None | RppmDebugView::DirectPhotons
        ) {
            encode_iteration(
                encoder,
                &node,
                state,
                &scene,
                slot,
                offset,
                timer,
                &mut checkpoints,
            );
        } else {
            #[cfg(feature = "debug")]
            crate::debug::encode_debug_iteration(
                encoder,
                debug_pipelines.get(&cache, state.debug_view),
                crate::debug::DebugInputs {
                    cache: &cache,
                    cubemap_pipelines: &cubemap_pipelines,
                    gbuffer_pipeline: gbuffer,
                    view: state.debug_view,
                    groups: [&state.scene_group, &state.params_group],
                    gbuffer: &state.gbuffer,
                    cubemap: state.cubemap.cubemap.as_ref(),
                    own: state.eye_paths.group.as_ref(),
                    size: state.key.size,
                    triangles: scene.triangle_count(),
                    offset,
                },
                timer,
            );
        }
        encode_estimate(encoder, &node, state, offset, timer, &mut checkpoints);
    }
    if let Some(c) = &mut checkpoints {
        c.iterations(count);
    }
    let resolving = state.resolves();
    if let Some(resolved) = state.estimate.resolved.as_ref().filter(|_| resolving) {
        let pass = (stages.resolve.and_then(|id| cache.get_compute_pipeline(id)))
            .zip(state.cubemap.cubemap.as_ref())
            .map(|(p, c)| (p, [&state.scene_group, &state.params_group, &c.trace_group]));
        let offset = (count.saturating_sub(1) as u64 * PARAMS_STRIDE) as u32;
        let radiance = &state.estimate.radiance;
        resolved.encode(encoder, pass, radiance, offset, state.key.size, timer);
    }
    let output = stages.output.and_then(|id| cache.get_render_pipeline(id));
    if let Some(output) = output {
        let group = state.output_group.pick(resolving);
        crate::output::encode(encoder, output, group, view_target, timer);
    }
    timer.end_frame(encoder);
}

/// Tracing and the sort's passes, when all are compiled.
fn photon_passes<'a>(
    cache: &'a PipelineCache,
    trace: Option<CachedComputePipelineId>,
    sort: Option<[CachedComputePipelineId; 4]>,
) -> Option<PhotonPasses<'a>> {
    let [a, b, c, d] = sort?.map(|id| cache.get_compute_pipeline(id));
    Some(PhotonPasses {
        trace: cache.get_compute_pipeline(trace?)?,
        sort: [a?, b?, c?, d?],
    })
}

/// One PPM iteration up to its photons: shadow maps when shadows are not traced (light maps
/// once per scene change, the area-light cube every iteration), the G-buffer, the cubemap,
/// eye paths, photon tracing.
#[expect(
    clippy::too_many_arguments,
    reason = "the view's state, its slot and its clocks"
)]
fn encode_iteration(
    encoder: &mut CommandEncoder,
    node: &NodePipelines,
    state: &RppmViewState,
    scene: &SceneBuffers,
    slot: u32,
    offset: u32,
    timer: &mut StageTimer,
    checkpoints: &mut Option<Checkpoints>,
) {
    let triangles = scene.triangle_count();
    if !state.traced_shadows {
        render_layers(
            encoder,
            node.shadow,
            &state.scene_group,
            &state.shadows,
            triangles,
            state.shadows.layers(slot).into_iter(),
            timer,
        );
        mark(checkpoints, encoder, Stage::ShadowMaps);
    }
    let groups = [&state.scene_group, &state.params_group];
    state
        .gbuffer
        .encode(encoder, node.gbuffer, groups, triangles, offset, timer);
    mark(checkpoints, encoder, Stage::GBuffer);
    let cubemap = state.cubemap.cubemap.as_ref();
    // Under RppmTracer::Bvh the lists are not traced: no build.
    if let Some(cubemap) = cubemap.filter(|_| !state.key.bvh) {
        cubemap.encode_build(encoder, node.cache, node.cubemap, &state.scene_group, timer);
        mark(checkpoints, encoder, Stage::CubemapBuild);
    }
    // Under RppmTracer::Bvh, the corners of triangles placed since the last iteration.
    if let Some(bvh) = &state.cubemap.bvh {
        let (device, cache, pipelines) = (node.device, node.cache, node.cubemap);
        (bvh.buffers).encode_fill(encoder, device, cache, pipelines, &state.scene_group);
    }
    if state.importons {
        state.eye_paths.encode_clear(encoder);
    }
    encoder.clear_buffer(&state.seen_region, 0, None);
    let trace_group = cubemap
        .filter(|_| state.importons || state.traced_shadows)
        .map(|c| &c.trace_group);
    state.eye_paths.encode(
        encoder,
        node.eye_paths,
        groups,
        offset,
        trace_group,
        state.key.size,
        timer,
    );
    mark(checkpoints, encoder, Stage::LocalIllumination);
    if let (true, Some(cubemap), Some(trace), Some(store)) =
        (state.photons > 0, cubemap, &node.photon, &state.store)
    {
        let groups = TracingGroups {
            scene: &state.scene_group,
            params: &state.params_group,
            offset,
            cubemap: &cubemap.trace_group,
        };
        let counts = [state.photons, state.photon_lanes()];
        store.encode_trace(encoder, trace.trace, &groups, counts, timer);
        mark(checkpoints, encoder, Stage::PhotonTrace);
        store.map.encode_sort(encoder, trace.sort, timer);
        mark(checkpoints, encoder, Stage::PhotonSort);
    }
}

/// Splats this iteration's photons (if any) and folds the sample into the estimate.
fn encode_estimate(
    encoder: &mut CommandEncoder,
    node: &NodePipelines,
    state: &RppmViewState,
    offset: u32,
    timer: &mut StageTimer,
    checkpoints: &mut Option<Checkpoints>,
) {
    let cubemap = state.cubemap.cubemap.as_ref();
    let traced = state.photons > 0 && cubemap.is_some() && node.photon.is_some();
    let groups = cubemap.filter(|_| traced).map(|cubemap| TracingGroups {
        scene: &state.scene_group,
        params: &state.params_group,
        offset,
        cubemap: &cubemap.trace_group,
    });
    state
        .splats
        .encode(encoder, node.splat, groups.as_ref(), timer);
    mark(checkpoints, encoder, Stage::Splat);
    if let (true, Some(groups), Some(indirect), Some(group)) = (
        state.importons,
        &groups,
        node.indirect_splat,
        &state.indirect_group,
    ) {
        crate::indirect_splat::encode(encoder, indirect, groups, group, &state.eye_paths, timer);
        mark(checkpoints, encoder, Stage::IndirectSplat);
    }
    if state.clamps {
        state.estimate.encode_keep_fresh(encoder);
    }
    state.estimate.encode(
        encoder,
        node.outliers,
        node.accumulate,
        &state.scene_group,
        state.key.size,
        offset,
        timer,
    );
    mark(checkpoints, encoder, Stage::Accumulate);
}
