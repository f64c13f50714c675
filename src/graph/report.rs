//! After submission: read back what was asked for and report each view to the main world.

use std::time::Instant;

use bevy::prelude::*;
use bevy::render::renderer::{RenderAdapterInfo, RenderDevice, RenderQueue};
use bevy::render::sync_world::MainEntity;

use super::state::{RppmViewState, ViewTimer};
use crate::photons::FrameCost;
use crate::scene::{RppmScene, SceneBuffers, SceneRefused};
use crate::settings::PhotonCount;
use crate::settings::RppmDebugView;
use crate::stats::readback::read_back;
use crate::stats::timing::Stage;
use crate::stats::{RadianceImage, RenderMessage, RenderSender, ViewStats};
use crate::view::ExtractedRppm;

/// The passes an iteration of this view runs, by the scene and settings (for the stats).
fn passes(state: &RppmViewState) -> Vec<String> {
    let debug = !matches!(
        state.debug_view,
        RppmDebugView::None | RppmDebugView::DirectPhotons
    );
    let has_cubemap = state.cubemap.cubemap.is_some();
    let traced = state.photons > 0 && has_cubemap;
    let output = state.stages.is_some_and(|s| s.output.is_some());
    [
        (
            "shadow_maps",
            !debug
                && !state.traced_shadows
                && (state.shadows.light_layers > 0 || state.shadows.has_area),
        ),
        ("traced_shadows", !debug && state.traced_shadows),
        ("gbuffer", state.debug_view != RppmDebugView::CubemapNormals),
        ("cubemap_build", has_cubemap && !state.key.bvh),
        ("local_illumination", !debug),
        ("importon_tracing", state.importons),
        ("photon_trace", traced),
        ("photon_sort", traced),
        ("splat", traced),
        ("indirect_splat", traced && state.importons),
        ("debug_view", debug),
        ("accumulate", true),
        ("output", output),
    ]
    .into_iter()
    .filter(|(_, runs)| *runs)
    .map(|(name, _)| name.to_string())
    .collect()
}

/// The scene on the GPU, why it was refused, and its extraction.
type SceneResources<'w> = (
    Option<Res<'w, SceneBuffers>>,
    Option<Res<'w, SceneRefused>>,
    Option<Res<'w, RppmScene>>,
);

pub(crate) fn report_views(
    mut views: Query<(
        &MainEntity,
        &mut RppmViewState,
        &mut ViewTimer,
        Option<&ExtractedRppm>,
    )>,
    (scene, refused, extracted): SceneResources,
    stateless: Query<&MainEntity, (With<ExtractedRppm>, Without<RppmViewState>)>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    adapter: Res<RenderAdapterInfo>,
    sender: Res<RenderSender>,
) {
    let scene_epoch = scene.as_ref().map_or(0, |s| s.epoch);
    let scene_paths: Vec<String> = scene
        .as_ref()
        .map(|s| {
            s.paths
                .shader_defs()
                .into_iter()
                .chain(s.lookups.shader_defs())
                .map(|p| p.to_string())
                .collect()
        })
        .unwrap_or_default();
    let scene_memory: Vec<(String, u64)> = scene
        .as_ref()
        .map(|s| {
            s.memory()
                .iter()
                .map(|(n, b)| (n.to_string(), *b))
                .collect()
        })
        .unwrap_or_default();
    // A view whose state was never made (the first scene was refused) still hears why.
    if let Some(refused) = &refused {
        for camera in &stateless {
            let error = Some(refused.0.clone());
            let _ = sender.send(RenderMessage::Stats(
                camera.id(),
                Box::new(ViewStats { error, ..default() }),
            ));
        }
    }
    for (camera, mut state, mut timer, rppm) in &mut views {
        let camera = camera.id();
        let wall_ms_per_iteration = timer
            .1
            .per_iteration()
            .into_iter()
            .map(|(s, ms)| (s.to_string(), ms))
            .collect();
        let timer = &mut timer.0;
        timer.start_readback();
        // A read-back frame waits for the GPU anyway; others only look.
        let waiting = state.readback_pending;
        let now = Instant::now();
        let wall_ms = state
            .last_report
            .replace(now)
            .map_or(0.0, |t| (now - t).as_secs_f64() * 1e3);
        if timer.collect(&device, waiting) {
            let cost = FrameCost {
                ms: timer.last_ms,
                work: timer.last_frame,
                // The clock's interval is the latest frame's; the timestamps' an earlier one
                // of the same count.
                wall_ms_per_iteration: wall_ms / state.frame.1.max(1) as f64,
            };
            let before = state.photon_count.count;
            let setting = rppm.map_or(PhotonCount::default(), |r| r.settings.photons_per_iteration);
            if state.photon_count.observe(setting, cost) {
                info!(
                    "bevy_rppm: {} photons per iteration (was {before}, {:.1} ms an iteration)",
                    state.photon_count.count,
                    state.photon_count.timing(before).map_or(0.0, |t| t.ms)
                );
            }
            let setting = rppm.map_or(default(), |r| r.settings.iterations_per_frame);
            let before = state.iterations.count;
            if state.iterations.observe(
                setting,
                cost.ms.iter().sum(),
                cost.work.iterations,
                cost.wall_ms_per_iteration,
                adapter.device_type == wgpu::DeviceType::Cpu,
            ) {
                debug!(
                    "bevy_rppm: {} iterations a frame (was {before}, {:.2} ms an iteration)",
                    state.iterations.count, state.iterations.ms
                );
            }
        }
        if waiting
            && let Some(bytes) = read_back(&device, &queue, state.estimate.shown(state.resolves()))
        {
            let pixels = bytemuck::cast_slice(&bytes).to_vec();
            let _ = sender.send(RenderMessage::Radiance(RadianceImage {
                camera,
                width: state.key.size.x,
                height: state.key.size.y,
                iteration: state.clock.iteration,
                epoch: changes_seen(scene_epoch, &state),
                pixels,
            }));
        }
        let second = |bytes: Vec<u8>| bytemuck::cast_slice::<u8, u32>(&bytes)[1];
        // The store's count, all frames: what the store is sized from.
        let counted = state.store.as_ref().and_then(|store| {
            if waiting {
                store.read_count(&device, &queue)
            } else {
                store.poll_count(&device)
            }
        });
        if let Some((stored, emitted)) = counted {
            let capacity = state.key.photon_capacity;
            state.photons_stored = stored.min(capacity);
            state.store_fit.observe(stored, emitted, capacity);
        }
        let made = (waiting && state.importons)
            .then(|| read_back(&device, &queue, &state.eye_paths.stats))
            .flatten();
        if let Some(bytes) = made {
            state.importons_made = second(bytes);
        }
        let mut memory = scene_memory.clone();
        memory.extend(state.memory());
        state.cubemap.read_counters(&device, &queue, waiting);
        let _ = sender.send(RenderMessage::Stats(
            camera,
            Box::new(ViewStats {
                epoch: changes_seen(scene_epoch, &state),
                iteration: state.clock.iteration,
                iterations_this_frame: state.frame.1,
                gpu_timing: timer.supported(),
                stage_ms: Stage::ALL
                    .iter()
                    .map(|s| s.name().to_string())
                    .zip(timer.last_ms)
                    .collect(),
                stage_ms_total: Stage::ALL
                    .iter()
                    .map(|s| s.name().to_string())
                    .zip(timer.total_ms)
                    .collect(),
                timed_iterations: timer.timed_iterations,
                wall_ms_per_iteration,
                memory: memory.into_iter().collect(),
                adapter: adapter.name.clone(),
                error: refused
                    .as_ref()
                    .map(|r| r.0.clone())
                    .or(state.error.clone()),
                cubemap_nodes: state.cubemap.nodes.0,
                photons_per_iteration: state.photons,
                photons_stored: state.photons_stored,
                photons_lost: state.store_fit.lost,
                importons: state.importons_made,
                passes: passes(&state),
                splat_radius_pixels: state.radius2.sqrt(),
                shader_paths: scene_paths.clone(),
                cubemap_overflow: state.cubemap.nodes.1,
                scene_upload_bytes: scene.as_ref().map_or(0, |s| s.upload_bytes),
                scene_geometry_bytes: scene.as_ref().map_or(0, |s| s.geometry_bytes()),
                scene_extract_ms: extracted.as_ref().map_or(0.0, |s| s.extract_ms),
                bvh_build_ms: state
                    .cubemap
                    .bvh
                    .as_ref()
                    .map_or(0.0, |b| b.buffers.build_ms),
                bvh_upload_bytes: state
                    .cubemap
                    .bvh
                    .as_ref()
                    .map_or(0, |b| b.buffers.upload_bytes),
            }),
        ));
    }
}

/// The epoch reported: changes seen so far, of the scene and of the camera (settings, moves).
fn changes_seen(scene_epoch: u64, state: &RppmViewState) -> u64 {
    scene_epoch
        .wrapping_add(state.view_epoch)
        .wrapping_add(state.view_moves)
}
