//! Each frame, per camera: make or keep the view's resources, reset accumulation on change,
//! pick the stage variants its scene and settings need (`stages.rs`), and write the
//! constants of this frame's iterations.

use bevy::prelude::*;
use bevy::render::camera::ExtractedCamera;
use bevy::render::renderer::{RenderAdapterInfo, RenderDevice, RenderQueue};
use bevy::render::texture::TextureCache;
use bevy::render::view::{ExtractedView, ViewTarget};

use super::stages::{Pipelines, select_stages, stages_ready};
use super::state::{ResourceKey, RppmViewState, ViewTimer};
use crate::accumulate::{Changes, HistoryFlags, history_fits, resolve_share};
use crate::cubemap::{self, BuildContext, CubemapConfig};
use crate::importons::{extra_importons, importons_fit};
use crate::output::output_key;
use crate::photons::{device_photon_count, store_capacity};
use crate::ppm::{next_radius2, photon_weight, radius2_after};
use crate::scene::{Lookups, ScatterPaths, SceneBuffers, SceneData};
use crate::settings::{PhotonCount, PhotonMapping, RppmDebugView, RppmMode};
use crate::shadows::cube_views;
use crate::stats::timing::StageTimer;
use crate::view::params::{camera_params, eye_of, halton_jitter, unjittered_clip_from_world};
use crate::view::{ExtractedRppm, PARAMS_STRIDE};

/// Whether camera paths go past the G-buffer (importons).
fn makes_importons(settings: &PhotonMapping, scene: &SceneData) -> bool {
    settings.max_eye_depth >= 2 && scene.has_path_surfaces()
}

fn cubemap_config(settings: &PhotonMapping) -> CubemapConfig {
    CubemapConfig {
        resolution: settings.cubemap_resolution,
        tile_size: settings.cubemap_tile_size,
        bins: settings.bins,
    }
}

/// Drops the state of cameras whose photon mapping went (removed or disabled), which frees
/// their GPU memory; without a scene on the GPU, every camera's.
pub(crate) fn drop_stale_views(
    mut commands: Commands,
    views: Query<(Entity, Has<ExtractedRppm>), With<RppmViewState>>,
    scene: Option<Res<SceneBuffers>>,
) {
    for (entity, extracted) in &views {
        if !extracted || scene.is_none() {
            commands
                .entity(entity)
                .remove::<(RppmViewState, ViewTimer)>();
        }
    }
}

type ViewItem<'a> = (
    Entity,
    &'a ExtractedView,
    &'a ExtractedCamera,
    &'a ExtractedRppm,
    &'a ViewTarget,
    Option<&'a mut RppmViewState>,
);

/// Makes or keeps each view's resources, resets accumulation on change, and writes the
/// constants of this frame's iterations.
#[expect(
    clippy::too_many_arguments,
    reason = "a system's parameters, one per resource"
)]
pub(crate) fn prepare_views(
    mut commands: Commands,
    mut views: Query<ViewItem>,
    scene: Option<Res<SceneBuffers>>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    mut textures: ResMut<TextureCache>,
    mut pipelines: Pipelines,
    adapter: Res<RenderAdapterInfo>,
    mut warned_indirect: Local<bool>,
) {
    let Some(scene) = scene.as_deref() else {
        return;
    };
    let (ready, error) = match pipelines.shared_ready() {
        Ok(ready) => (ready, None),
        Err(e) => (false, Some(e)),
    };
    for (entity, view, camera, rppm, view_target, existing) in &mut views {
        let Some(size) = camera.physical_viewport_size.filter(|s| s.x > 0 && s.y > 0) else {
            continue; // a zero-sized target renders nothing; keep the state for when it returns
        };
        let settings = &rppm.settings;
        let (software, triangles) = (
            adapter.device_type == wgpu::DeviceType::Cpu,
            scene.triangle_count(),
        );
        // A state made anew below keeps the controllers and the store's counts.
        let (mut photon_count, iterations, store_fit, store_now) = existing
            .as_deref()
            .map(RppmViewState::kept)
            .unwrap_or_default();
        let photon_setting = device_photon_count(settings.photons_per_iteration, &device);
        let photons = photon_count.count(photon_setting);
        let importons = makes_importons(settings, &scene.data) && importons_fit(&device, size);
        let textured = scene.lookups.contains(Lookups::TEXTURED);
        let key = ResourceKey {
            size,
            slots: settings.iterations_per_frame.max(),
            shadow_resolution: settings.shadow_map_resolution,
            photon_capacity: store_capacity(
                settings, photons, scene, &device, &store_fit, store_now,
            ),
            importons,
            extra_importons: extra_importons(
                &device,
                size,
                importons && scene.paths.contains(ScatterPaths::ROUGH_REFRACTION),
            ),
            photon_tiles: cubemap::fitted(cubemap_config(settings), &device).tiles(),
            subsampling: settings.indirect_subsampling,
            history: settings.history.window().is_some()
                && history_fits(&device, size, importons, textured),
            // A hierarchy too large for this device's textures gives way to the cubemap.
            bvh: settings.tracer.uses_bvh() && cubemap::bvh::fits(&device, triangles),
            textured,
            photons_per_lane: crate::photons::photons_per_lane(software),
            adaptive_kernel: settings.adaptive_kernel && settings.indirect_subsampling == 1,
        };
        let fresh = |pipelines: &Pipelines, textures: &mut TextureCache| {
            RppmViewState::new(
                key,
                &device,
                &queue,
                &pipelines.cache,
                textures,
                &pipelines.stages(),
                scene,
            )
        };
        // A new state takes this frame's targets; one kept takes them again below.
        let mut made = None;
        let mut targets_taken = false;
        let state = match existing {
            Some(state) => state.into_inner(),
            None => {
                targets_taken = true;
                made.insert(fresh(&pipelines, &mut textures))
            }
        };
        if state.key != key {
            let same_but_store = ResourceKey {
                photon_capacity: key.photon_capacity,
                ..state.key
            } == key;
            if same_but_store {
                let stages = pipelines.stages();
                state.resize_store(key.photon_capacity, &device, &pipelines.cache, &stages);
            } else {
                *state = fresh(&pipelines, &mut textures);
                targets_taken = true;
            }
        }
        state.photon_count = photon_count;
        state.iterations = iterations;
        state.store_fit = store_fit;
        if state.scene_epoch != scene.epoch {
            state.rebind_scene(
                &device,
                &queue,
                &pipelines.cache,
                &pipelines.stages(),
                scene,
            );
        }
        if !targets_taken {
            let stages = pipelines.stages();
            state.refresh_targets(&device, &pipelines.cache, &mut textures, &stages);
        }
        let output = output_key(settings.mode, camera, view_target, &mut warned_indirect);
        let frame = Frame {
            view,
            camera,
            rppm,
            photon_setting,
            output,
            ready,
            error: error.clone(),
        };
        prepare_view(state, frame, scene, &device, &queue, &mut pipelines);
        if let Some(state) = made {
            let timer = StageTimer::new(&device, &queue, 4096);
            commands
                .entity(entity)
                .insert((state, ViewTimer(timer, default())));
        }
    }
}

/// What one view's frame is prepared from.
struct Frame<'a> {
    view: &'a ExtractedView,
    camera: &'a ExtractedCamera,
    rppm: &'a ExtractedRppm,
    /// The photon count setting as this device takes it.
    photon_setting: PhotonCount,
    output: Option<crate::output::OutputKey>,
    /// Whether the pipelines every view shares are compiled.
    ready: bool,
    error: Option<String>,
}

fn prepare_view(
    state: &mut RppmViewState,
    frame: Frame,
    scene: &SceneBuffers,
    device: &RenderDevice,
    queue: &RenderQueue,
    pipelines: &mut Pipelines,
) {
    let settings = &frame.rppm.settings;
    let key = state.key;
    let window = settings.history.window().filter(|_| key.history);
    let changes = Changes {
        cut: state.view_epoch != frame.rppm.view_epoch || std::mem::take(&mut state.scene_reshaped),
        moved: state.view_moves != frame.rppm.view_moves,
        scene: std::mem::take(&mut state.scene_changed),
        relit: std::mem::take(&mut state.scene_relit),
    };
    state.view_epoch = frame.rppm.view_epoch;
    state.view_moves = frame.rppm.view_moves;
    // For the count timing chose, or the most there may be until it chose
    // (`PhotonController::radius_count`); a new count scales the sequence's radius with it.
    let radius_photons = state.photon_count.radius_count(frame.photon_setting);
    let initial_for = |photons| (settings.initial_radius.pixels(key.size, photons) as f64).powi(2);
    if state.radius_photons != radius_photons {
        if state.radius_photons > 0 {
            state.radius2 *= initial_for(radius_photons) / initial_for(state.radius_photons);
        }
        state.radius_photons = radius_photons;
    }
    let initial = || initial_for(radius_photons);
    let caustic_scale = settings
        .initial_radius
        .caustic_scale(key.size, radius_photons);
    // A new start, or a change under `Reuse` (its held count is back at 0).
    let restarted = state.clock.begin_frame(changes, window);
    if restarted || changes.moved || changes.scene {
        // Under `Reuse` a change keeps a window of each pixel's history, whose radius it
        // goes on from (`HistoryClock::radius_index`), and a scene change the pixels'
        // kernel statistics within that window (they are of the same surfaces; a camera
        // move's are of others).
        state.radius2 = radius2_after(initial(), state.clock.radius_index(), settings.alpha);
        state.radius_restart |= restarted || changes.moved;
    }
    if restarted {
        state.since_move = None;
    }
    if let Some(target) = frame
        .rppm
        .fast_forward
        .filter(|&f| state.fast_forward != Some(f))
    {
        state.fast_forward = Some(target);
        state.radius2 = radius2_after(initial(), target, settings.alpha);
        state.radius_restart = true;
        state.clock.fast_forward(target);
    }
    let estimate = matches!(
        settings.debug_view,
        RppmDebugView::None | RppmDebugView::DirectPhotons
    );
    state.photons = if key.photon_capacity > 0 && estimate {
        state.photon_count.count
    } else {
        0
    };
    state.mode = settings.mode;
    state.debug_view = settings.debug_view;
    state.profile = settings.profile_stages;
    state.error = frame.error;
    state.importons = key.importons && settings.debug_view == RppmDebugView::None;
    // Shadow rays need the cubemap too: it is built whenever something lights the scene.
    let lit = estimate && !scene.data.light_cdf.is_empty();
    let traces = state.photons > 0
        || state.importons
        || lit
        || settings.debug_view == RppmDebugView::CubemapNormals;
    let config = traces.then(|| cubemap_config(settings));
    let centre = frame.view.world_from_view.translation();
    let ctx = BuildContext {
        device,
        queue,
        cache: &pipelines.cache,
        pipelines: &pipelines.cubemap,
        scene,
        scene_group: &state.scene_group,
    };
    if let Err(e) = state.cubemap.prepare(config, centre, key.bvh, &ctx) {
        state.error = Some(e);
    }
    // Importons need the cubemap bound; without one (its buffers refused) none are made.
    state.importons &= state.cubemap.cubemap.is_some();
    // Without a cubemap (its buffers refused) shadows fall back to shadow maps.
    state.traced_shadows = lit && state.cubemap.cubemap.is_some();
    if lit && !state.traced_shadows && !state.shadows.mapped {
        state.shadows.mapped = true; // made for real by the rebind
        state.rebind_scene(device, queue, &pipelines.cache, &pipelines.stages(), scene);
    }
    state.stages = Some(select_stages(state, scene, frame.output, pipelines));
    let ready = match stages_ready(state, &pipelines.cache) {
        Ok(view_ready) => frame.ready && view_ready,
        Err(e) => {
            state.error = Some(e);
            false
        }
    };
    let base = state.clock.iteration;
    // Iterations held, not run: under `Reuse` a change makes room for new ones.
    let budget = settings
        .max_iterations
        .map_or(u32::MAX, |m| m.saturating_sub(state.clock.held));
    let count = if ready {
        state
            .iterations
            .count(settings.iterations_per_frame)
            .min(budget)
    } else {
        0
    };
    let (_, first_flags) = state.clock.next(window);
    // Last frame's copies are made when an iteration first reads them: a still view reads
    // none.
    if first_flags.clamps() {
        state.keep_previous(device, &pipelines.cache, &pipelines.stages());
    }
    state.reprojects = count > 0 && first_flags.contains(HistoryFlags::REPROJECT);
    state.since_move = match state.since_move {
        _ if state.reprojects => Some(0),
        since => since.map(|n| n.saturating_add(count)),
    };
    // A debug view is shown as it is.
    state.resolve_share = (state.since_move)
        .zip(window)
        .filter(|_| settings.debug_view == RppmDebugView::None)
        .map_or(0.0, |(since, window)| resolve_share(window, since));
    state.clamps = false;
    state.kernels_restart = false;
    for slot in 0..count.max(1) {
        let iteration = base + slot;
        // Under `Reuse` the jitter goes on through a scene's motion: a pixel's history
        // averages positions across it (its edges anti-aliased), as a still estimate's
        // iterations do. A frame whose camera moved rasterizes all its iterations at one:
        // history reprojected from where an edge was cannot tell its coverage, so each
        // pixel's samples are of one surface, and the frame's edges are resolved from their
        // subpixels (`crate::accumulate::Resolved`; the still frames after it show a falling
        // share of that). Its iterations still shade each pixel at the sequence's points
        // where they meet the pixel's surface (a highlight is sampled across the pixel:
        // `shading_jitter`).
        let jitter = halton_jitter(if state.reprojects { 0 } else { iteration });
        let mut params = camera_params(
            frame.view,
            frame.camera,
            key.size,
            &scene.data,
            iteration,
            settings.seed,
            jitter,
        );
        if state.reprojects {
            params.shading_jitter = (jitter - halton_jitter(slot)).into();
        }
        params.resolve_share = state.resolve_share;
        let (cap, flags) = state.clock.next(window);
        params.history_cap = cap;
        params.history_flags = flags.bits();
        state.clamps |= slot < count && flags.clamps();
        params.previous_clip_from_world = state.previous_clip_from_world.to_cols_array_2d();
        params.previous_eye = eye_of(state.previous_clip_from_world).into();
        params.area_view = state.shadows.area_view_base(slot);
        params.area_layer = state.shadows.light_layers;
        params.shadow_resolution = state.shadows.resolution;
        params.photons = state.photons;
        params.photon_lanes = state.photon_lanes();
        params.max_photon_depth = settings.max_photon_depth;
        params.photon_capacity = key.photon_capacity;
        params.source_count = scene.data.light_cdf.len() as u32;
        params.splat_radius = state.radius2.sqrt() as f32;
        params.caustic_scale = caustic_scale;
        params.photon_weight = photon_weight(state.photons, state.radius_photons);
        params.max_eye_depth = settings.max_eye_depth;
        params.splat_russian_roulette = settings.splat_russian_roulette as u32;
        params.direct_photons = (settings.debug_view == RppmDebugView::DirectPhotons) as u32;
        params.indirect_only = (settings.mode == RppmMode::Indirect) as u32;
        params.kernel_flattening = settings.kernel_flattening;
        params.indirect_subsampling = settings.indirect_subsampling;
        let restart = slot < count && std::mem::take(&mut state.radius_restart);
        params.radius_restart = restart as u32;
        state.kernels_restart |= restart;
        if slot < count {
            let index = state.clock.radius_index();
            state.radius2 = next_radius2(state.radius2, index, settings.alpha);
            state.clock.advance();
        }
        queue.write_buffer(
            &state.params,
            slot as u64 * PARAMS_STRIDE,
            bytemuck::bytes_of(&params),
        );
        if slot < count && state.shadows.has_area && !state.traced_shadows {
            let eye = Vec4::from(params.area_position).truncate()
                + Vec4::from(params.area_normal).truncate() * scene.data.bounding_sphere().1 * 1e-4;
            let views = cube_views(eye, &scene.data, state.shadows.resolution);
            state.shadows.write_area_views(queue, slot, &views);
        }
    }
    // Debug images and traced shadows render no shadow maps; their frames leave the light
    // maps due.
    let mapped = estimate && !state.traced_shadows;
    state
        .shadows
        .schedule_light_maps(scene.epoch, if mapped { count } else { 0 });
    state.frame = (base, count);
    if count > 0 {
        state.previous_clip_from_world = unjittered_clip_from_world(frame.view);
    }
    state.readback_pending = frame.rppm.readback;
}
