//! Per-camera PPM state in the render world: targets, the iteration counter that a scene or
//! view change resets, the per-iteration constants, and the render-graph node that runs the
//! iterations of a frame.

use bevy::platform::collections::HashMap;
use bevy::prelude::*;
use bevy::render::camera::ExtractedCamera;
use bevy::render::render_resource::*;
use bevy::render::renderer::{
    RenderAdapterInfo, RenderContext, RenderDevice, RenderQueue, ViewQuery,
};
use bevy::render::sync_world::MainEntity;
use bevy::render::view::{ExtractedView, ViewTarget};
use bytemuck::{Pod, Zeroable};

use crate::cubemap::{CubemapConfig, CubemapPipelines, DeepCubemap};
use crate::debug_view::DebugViewPipelines;
use crate::output::{RadianceImage, RenderMessage, RenderSender, ViewStats, read_back};
use crate::photons::{
    PHOTON_BYTES, PhotonPipelines, PhotonStageIds, PhotonTargets, TargetInputs, TracingGroups,
};
use crate::pipelines::{DEPTH_FORMAT, GBUFFER_FORMAT, RppmPipelines};
use crate::scene::gpu::SceneBuffers;
use crate::scene::{GpuTriangle, SceneData};
use crate::settings::{PhotonMapping, RppmDebugView, RppmMode};
use crate::shadows::{self, ShadowMaps};
use crate::timing::{Stage, StageTimer};

/// Byte stride between per-iteration slots of the params buffer (dynamic-offset alignment).
const PARAMS_STRIDE: u64 = 512;

/// Per-iteration constants (`IterationParams` in common.wgsl, 304 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct IterationParams {
    pub clip_from_world: [[f32; 4]; 4],
    pub world_from_clip: [[f32; 4]; 4],
    pub camera_position: [f32; 4],
    pub area_position: [f32; 4],
    pub area_normal: [f32; 4],
    pub area_weight: [f32; 4],
    pub size: [u32; 2],
    pub iteration: u32,
    pub light_count: u32,
    pub pixel_spread: f32,
    pub orthographic: u32,
    pub area_view: u32,
    pub area_layer: u32,
    pub shadow_resolution: u32,
    pub exposure: f32,
    pub tonemap: u32,
    pub photons: u32,
    pub max_photon_depth: u32,
    pub photon_capacity: u32,
    pub source_count: u32,
    pub splat_radius: f32,
    pub max_eye_depth: u32,
    pub splat_russian_roulette: u32,
    pub direct_photons: u32,
    pub indirect_only: u32,
    pub scene_sphere: [f32; 4],
    pub kernel_flattening: f32,
    pub indirect_subsampling: u32,
    pub pad: [u32; 2],
}

/// The camera's settings and change counter, in the render world.
#[derive(Component, Clone)]
pub struct ExtractedRppm {
    pub settings: PhotonMapping,
    pub view_epoch: u64,
    pub readback: bool,
    pub fast_forward: Option<u32>,
}

/// What forces the view's GPU resources to be made anew.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
struct ResourceKey {
    size: UVec2,
    slots: u32,
    shadow_resolution: u32,
    /// Room for stored photons: photons per iteration × max photon depth; 0 without lights.
    photon_capacity: u32,
    /// Cubemap tiles importons register in; 0 when camera paths end at the G-buffer.
    importon_tiles: u32,
    /// Photons splat on every n-th pixel (the splat target's size follows).
    subsampling: u32,
}

pub struct ViewState {
    key: ResourceKey,
    view_epoch: u64,
    /// Iterations accumulated since the last reset.
    pub iteration: u32,
    /// First iteration and count run this frame.
    frame: (u32, u32),
    /// Squared gather radius in pixels for the next iteration (Knaus–Zwicker sequence).
    radius2: f64,
    /// The last `RppmFastForward` applied.
    fast_forward: Option<u32>,
    /// Photons emitted per iteration this frame (0: no photon passes).
    photons: u32,
    /// Whether camera paths go past the G-buffer this frame (importon tracing and indirect
    /// splatting).
    importons: bool,
    photon_targets: PhotonTargets,
    /// Photons stored, and importons made, by the last iteration read back.
    photons_stored: u32,
    importons_made: u32,
    mode: RppmMode,
    debug_view: RppmDebugView,
    /// The deep cubemap, while a stage that traces rays needs one.
    cubemap: Option<DeepCubemap>,
    /// List capacity for the next cubemap made, raised when a build overflowed.
    cubemap_capacity: u32,
    /// (nodes used, nodes lost) of the last build read back.
    cubemap_nodes: (u32, u32),
    output_pipeline: Option<CachedRenderPipelineId>,
    /// Local illumination and photon stages for this scene's paths and these settings.
    local_pipeline: CachedComputePipelineId,
    photon_stages: Option<PhotonStageIds>,
    gbuffer_position: TextureView,
    gbuffer_normal: TextureView,
    gbuffer_depth: TextureView,
    radiance: Buffer,
    params: Buffer,
    shadows: ShadowMaps,
    scene_group: BindGroup,
    params_group: BindGroup,
    local_group: BindGroup,
    output_group: BindGroup,
    timer: StageTimer,
    readback_pending: bool,
    /// Scene epoch the scene-dependent resources (shadow maps, bind groups) were made for.
    scene_epoch: u64,
    error: Option<String>,
}

/// Every PPM view, by main-world camera entity. A camera that loses its `PhotonMapping` (or
/// disables it) drops its entry, which frees its GPU memory.
#[derive(Resource, Default)]
pub struct RppmViews(HashMap<Entity, ViewState>);

fn target(
    device: &RenderDevice,
    label: &'static str,
    size: UVec2,
    format: TextureFormat,
) -> TextureView {
    device
        .create_texture(&TextureDescriptor {
            label: Some(label),
            size: Extent3d {
                width: size.x,
                height: size.y,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: TextureDimension::D2,
            format,
            usage: TextureUsages::RENDER_ATTACHMENT | TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        })
        .create_view(&TextureViewDescriptor::default())
}

fn params_binding(params: &Buffer) -> BufferBinding<'_> {
    BufferBinding {
        buffer: params,
        offset: 0,
        size: BufferSize::new(std::mem::size_of::<IterationParams>() as u64),
    }
}

impl ViewState {
    fn new(
        key: ResourceKey,
        device: &RenderDevice,
        queue: &RenderQueue,
        cache: &PipelineCache,
        pipelines: &RppmPipelines,
        photon_pipelines: &PhotonPipelines,
        scene: &SceneBuffers,
    ) -> Self {
        let size = key.size;
        let gbuffer_position = target(device, "rppm_gbuffer_position", size, GBUFFER_FORMAT);
        let gbuffer_normal = target(device, "rppm_gbuffer_normal", size, GBUFFER_FORMAT);
        let gbuffer_depth = target(device, "rppm_gbuffer_depth", size, DEPTH_FORMAT);
        let pixels = size.x as u64 * size.y as u64;
        let radiance = device.create_buffer(&BufferDescriptor {
            label: Some("rppm_radiance"),
            size: pixels * 16,
            usage: BufferUsages::STORAGE | BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let params = device.create_buffer(&BufferDescriptor {
            label: Some("rppm_iteration_params"),
            size: key.slots as u64 * PARAMS_STRIDE,
            usage: BufferUsages::UNIFORM | BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let photon_targets = PhotonTargets::new(
            device,
            cache,
            photon_pipelines,
            TargetInputs {
                size,
                params: params_binding(&params),
                radiance: &radiance,
                gbuffer_position: &gbuffer_position,
                gbuffer_normal: &gbuffer_normal,
                photon_capacity: key.photon_capacity,
                importon_tiles: key.importon_tiles,
                subsampling: key.subsampling,
            },
        );
        let params_group = device.create_bind_group(
            "rppm_params_group",
            &cache.get_bind_group_layout(&pipelines.params_layout),
            &BindGroupEntries::single(params_binding(&params)),
        );
        let output_group = device.create_bind_group(
            "rppm_output_group",
            &cache.get_bind_group_layout(&pipelines.output_layout),
            &BindGroupEntries::sequential((params_binding(&params), radiance.as_entire_binding())),
        );
        let (shadows, scene_group, local_group) = scene_resources(
            key,
            device,
            queue,
            cache,
            pipelines,
            scene,
            &photon_targets,
            [&gbuffer_position, &gbuffer_normal],
        );
        Self {
            key,
            view_epoch: u64::MAX,
            iteration: 0,
            frame: (0, 0),
            radius2: 0.0,
            fast_forward: None,
            photons: 0,
            importons: false,
            photon_targets,
            photons_stored: 0,
            importons_made: 0,
            mode: RppmMode::Full,
            debug_view: RppmDebugView::None,
            cubemap: None,
            cubemap_capacity: 0,
            cubemap_nodes: (0, 0),
            output_pipeline: None,
            local_pipeline: pipelines.local_illumination,
            photon_stages: None,
            gbuffer_position,
            gbuffer_normal,
            gbuffer_depth,
            radiance,
            params,
            shadows,
            scene_group,
            params_group,
            local_group,
            output_group,
            timer: StageTimer::new(device, queue, 4096),
            readback_pending: false,
            scene_epoch: scene.epoch,
            error: None,
        }
    }
}

impl ViewState {
    /// A changed scene keeps the view's targets: only what depends on the scene's lights and
    /// buffers is made again, and accumulation restarts.
    fn rebind_scene(
        &mut self,
        device: &RenderDevice,
        queue: &RenderQueue,
        cache: &PipelineCache,
        pipelines: &RppmPipelines,
        scene: &SceneBuffers,
    ) {
        (self.shadows, self.scene_group, self.local_group) = scene_resources(
            self.key,
            device,
            queue,
            cache,
            pipelines,
            scene,
            &self.photon_targets,
            [&self.gbuffer_position, &self.gbuffer_normal],
        );
        if let Some(cubemap) = &mut self.cubemap {
            cubemap.set_scene(queue, scene);
        }
        self.scene_epoch = scene.epoch;
        self.iteration = 0;
    }

    /// Bytes held per buffer or texture of the view.
    fn memory(&self) -> Vec<(String, u64)> {
        let pixels = self.key.size.x as u64 * self.key.size.y as u64;
        let mut memory: Vec<(String, u64)> = self
            .photon_targets
            .memory()
            .into_iter()
            .chain([
                ("gbuffer", pixels * (16 + 16 + 4)),
                ("radiance", self.radiance.size()),
                ("iteration_params", self.params.size()),
                ("shadow_maps", self.shadows.bytes()),
                ("timestamps", 4096 * 8 * 2),
            ])
            .map(|(n, b)| (n.to_string(), b))
            .collect();
        if let Some(cubemap) = &self.cubemap {
            memory.extend(cubemap.memory().iter().map(|(n, b)| (n.to_string(), *b)));
        }
        memory
    }
}

/// The view's shadow maps and the bind groups that hold scene buffers: group 0 (the scene)
/// and group 2 of the local stage (which samples the shadow maps).
#[allow(clippy::too_many_arguments)]
fn scene_resources(
    key: ResourceKey,
    device: &RenderDevice,
    queue: &RenderQueue,
    cache: &PipelineCache,
    pipelines: &RppmPipelines,
    scene: &SceneBuffers,
    photon_targets: &PhotonTargets,
    [gbuffer_position, gbuffer_normal]: [&TextureView; 2],
) -> (ShadowMaps, BindGroup, BindGroup) {
    let shadows = ShadowMaps::new(device, &scene.data, key.shadow_resolution, key.slots);
    shadows.write_light_views(queue, &scene.data);
    let scene_group = scene.bind_group(device, cache, &pipelines.scene_layout, &shadows.views);
    let local_group = device.create_bind_group(
        "rppm_local_group",
        &cache.get_bind_group_layout(&pipelines.local_layout),
        &BindGroupEntries::sequential((
            gbuffer_position,
            gbuffer_normal,
            &shadows.array_view,
            photon_targets.samples.as_entire_binding(),
            photon_targets.importons.as_entire_binding(),
            photon_targets.importon_heads.as_entire_binding(),
            photon_targets.importon_stats.as_entire_binding(),
        )),
    );
    (shadows, scene_group, local_group)
}

/// A deterministic hash of the iteration, the source of this iteration's random numbers.
fn pcg(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

fn unit_random(seed: &mut u32) -> f32 {
    *seed = pcg(*seed);
    (*seed >> 8) as f32 / (1u32 << 24) as f32
}

/// Radical inverse in `base`: a low-discrepancy sub-pixel jitter sequence.
fn halton(mut i: u32, base: u32) -> f32 {
    let (mut f, mut r) = (1.0f32, 0.0f32);
    while i > 0 {
        f /= base as f32;
        r += f * (i % base) as f32;
        i /= base;
    }
    r
}

/// A point on the emissive surfaces chosen by power, with radiance divided by its area pdf.
fn area_sample(data: &SceneData, iteration: u32) -> Option<(Vec3, Vec3, Vec3)> {
    let mut seed = pcg(iteration ^ 0x9e37_79b9);
    let u = unit_random(&mut seed);
    let index = data
        .emitters
        .partition_point(|e| e.cdf < u)
        .min(data.emitters.len().checked_sub(1)?);
    let emitter = data.emitters[index];
    let previous = if index == 0 {
        0.0
    } else {
        data.emitters[index - 1].cdf
    };
    let probability = (emitter.cdf - previous).max(1e-12);
    let triangle: &GpuTriangle = &data.triangles[emitter.triangle as usize];
    let [a, b, c] = triangle.positions();
    let (r1, r2) = (unit_random(&mut seed).sqrt(), unit_random(&mut seed));
    let point = a * (1.0 - r1) + b * (r1 * (1.0 - r2)) + c * (r1 * r2);
    let normal = (b - a).cross(c - a).normalize();
    let emissive = Vec4::from(data.materials[triangle.material as usize].emissive).truncate();
    let weight = emissive * (emitter.area / probability);
    Some((point, normal, weight))
}

#[allow(clippy::too_many_arguments)]
fn iteration_params(
    view: &ExtractedView,
    camera: &ExtractedCamera,
    state: &ViewState,
    data: &SceneData,
    iteration: u32,
    slot: u32,
) -> IterationParams {
    let size = state.key.size;
    let jitter = Vec2::new(halton(iteration + 1, 2), halton(iteration + 1, 3)) - 0.5;
    let offset = Vec3::new(
        2.0 * jitter.x / size.x as f32,
        -2.0 * jitter.y / size.y as f32,
        0.0,
    );
    let view_from_world = view.world_from_view.to_matrix().inverse();
    let clip_from_world = Mat4::from_translation(offset) * view.clip_from_view * view_from_world;
    let orthographic = view.clip_from_view.w_axis.w == 1.0;
    let pixel_spread = 2.0 / (view.clip_from_view.y_axis.y * size.y as f32);
    let area = area_sample(data, iteration);
    let (area_position, area_normal, area_weight) = match area {
        Some((p, n, w)) => (p.extend(1.0), n.extend(0.0), w.extend(0.0)),
        None => (Vec4::ZERO, Vec4::ZERO, Vec4::ZERO),
    };
    IterationParams {
        clip_from_world: clip_from_world.to_cols_array_2d(),
        world_from_clip: clip_from_world.inverse().to_cols_array_2d(),
        camera_position: view.world_from_view.translation().extend(1.0).into(),
        area_position: area_position.into(),
        area_normal: area_normal.into(),
        area_weight: area_weight.into(),
        size: size.into(),
        iteration,
        light_count: data.lights.len() as u32,
        pixel_spread,
        orthographic: orthographic as u32,
        area_view: state.shadows.area_view_base(slot),
        area_layer: state.shadows.light_layers,
        shadow_resolution: state.shadows.resolution,
        exposure: camera.exposure,
        tonemap: (!camera.hdr) as u32,
        photons: 0,
        max_photon_depth: 0,
        photon_capacity: 0,
        source_count: 0,
        splat_radius: 0.0,
        max_eye_depth: 1,
        splat_russian_roulette: 0,
        direct_photons: 0,
        indirect_only: 0,
        scene_sphere: {
            let (centre, radius) = data.bounding_sphere();
            centre.extend(radius.max(1e-6)).into()
        },
        kernel_flattening: 0.1,
        indirect_subsampling: 1,
        pad: [0; 2],
    }
}

/// How the estimate reaches the view: replacing it (Full), or added to Bevy's own lighting
/// before tonemapping (Indirect, which needs an HDR view: without one Bevy tonemaps inside its
/// shaders, and linear light added afterwards would be wrong, so nothing is added).
fn output_pipeline(
    pipelines: &mut RppmPipelines,
    cache: &PipelineCache,
    mode: RppmMode,
    camera: &ExtractedCamera,
    target: &ViewTarget,
    warned: &mut bool,
) -> Option<CachedRenderPipelineId> {
    let additive = mode == RppmMode::Indirect;
    if additive && !camera.hdr {
        if !*warned {
            warn!(
                "bevy_rppm: RppmMode::Indirect needs an HDR camera (add `Hdr`); showing Bevy's image alone"
            );
            *warned = true;
        }
        return None;
    }
    Some(pipelines.output_pipeline(cache, target.main_texture_format(), additive))
}

/// Whether every pipeline of an iteration is ready, or the first one that failed to build.
/// Photons the view's store must hold: a photon is stored at each non-specular hit after its
/// first (direct light is the local stage's), at most `max_photon_depth - 1` times, and goes on
/// after a hit with probability at most p (the scene's largest albedo), so the store holds the
/// expected Σ pʲ stores per photon with a margin. Capped by the GPU's largest storage binding;
/// 0 when nothing emits or no photon can be stored.
fn photon_capacity(settings: &PhotonMapping, scene: &SceneBuffers, device: &RenderDevice) -> u32 {
    let direct = settings.debug_view == RppmDebugView::DirectPhotons;
    let stores = if direct {
        1
    } else {
        settings.max_photon_depth - 1
    };
    if scene.data.light_cdf.is_empty() || settings.photons_per_iteration == 0 || stores == 0 {
        return 0;
    }
    let photons = settings.photons_per_iteration as f64;
    let wanted = if direct {
        photons
    } else {
        let p = scene.max_scatter as f64;
        let expected: f64 = (1..=stores).map(|j| p.powi(j as i32)).sum();
        // 4 standard deviations of a binomial count over the photons, and never more than
        // every photon stored at every bounce.
        let margin = 4.0 * (photons * stores as f64).sqrt() + 1024.0;
        (photons * expected * 1.1 + margin).min(photons * stores as f64)
    };
    let limit = device.limits().max_storage_buffer_binding_size / PHOTON_BYTES;
    (wanted.ceil() as u64).min(limit).min(u32::MAX as u64) as u32
}

/// Tiles of the view's cubemap, when camera paths go past the G-buffer; else 0.
fn importon_tiles(settings: &PhotonMapping, scene: &SceneData) -> u32 {
    if settings.max_eye_depth < 2 || !scene.has_specular_surfaces() {
        return 0;
    }
    let grid = CubemapConfig {
        resolution: settings.cubemap_resolution,
        tile_size: settings.cubemap_tile_size,
        bins: settings.bins,
    }
    .grid();
    6 * grid * grid
}

/// Knaus–Zwicker: r²ᵢ₊₁ = r²ᵢ (i + α)/(i + 1), with i counted from 1 (`iteration` from 0).
pub fn next_radius2(radius2: f64, iteration: u32, alpha: f32) -> f64 {
    let i = iteration as f64 + 1.0;
    radius2 * (i + alpha as f64) / (i + 1.0)
}

/// r² after `iterations` Knaus–Zwicker steps from `initial`.
pub fn radius2_after(initial: f64, iterations: u32, alpha: f32) -> f64 {
    (0..iterations).fold(initial, |r2, i| next_radius2(r2, i, alpha))
}

fn pipelines_ready(pipelines: &RppmPipelines, cache: &PipelineCache) -> Result<bool, String> {
    readiness([
        cache.get_render_pipeline_state(pipelines.shadow),
        cache.get_render_pipeline_state(pipelines.gbuffer),
        cache.get_compute_pipeline_state(pipelines.local_illumination),
    ])
}

/// Whether every pipeline is compiled; an error when one failed to build.
fn readiness<'a>(
    states: impl IntoIterator<Item = &'a CachedPipelineState>,
) -> Result<bool, String> {
    let mut ready = true;
    for state in states {
        match state {
            CachedPipelineState::Err(e) => {
                return Err(format!("a bevy_rppm pipeline failed to build: {e}"));
            }
            CachedPipelineState::Ok(_) => {}
            _ => ready = false,
        }
    }
    Ok(ready)
}

/// Whether the stage variants this view selected are compiled.
fn stages_ready(state: &ViewState, cache: &PipelineCache) -> Result<bool, String> {
    let Some(stages) = state.photon_stages else {
        return Ok(false);
    };
    let compute = [
        Some(state.local_pipeline),
        Some(stages.accumulate),
        stages.trace,
        stages.indirect_splat,
    ];
    let splat = stages.splat.map(|id| cache.get_render_pipeline_state(id));
    readiness(
        compute
            .into_iter()
            .flatten()
            .map(|id| cache.get_compute_pipeline_state(id))
            .chain(splat),
    )
}

/// Makes or keeps each view's resources, resets accumulation on change, and writes the
/// constants of this frame's iterations.
#[allow(clippy::too_many_arguments)]
pub(crate) fn prepare_views(
    views: Query<(
        &MainEntity,
        &ExtractedView,
        &ExtractedCamera,
        &ExtractedRppm,
        &ViewTarget,
    )>,
    scene: Option<Res<SceneBuffers>>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    cache: Res<PipelineCache>,
    mut pipelines: ResMut<RppmPipelines>,
    cubemap_pipelines: Res<CubemapPipelines>,
    mut photon_pipelines: ResMut<PhotonPipelines>,
    mut states: ResMut<RppmViews>,
    mut warned_indirect: Local<bool>,
) {
    let mut alive = Vec::new();
    let (ready, error) = match pipelines_ready(&pipelines, &cache) {
        Ok(ready) => (ready, None),
        Err(e) => (false, Some(e)),
    };
    for (main, view, camera, rppm, view_target) in &views {
        let Some(scene) = scene.as_deref() else {
            continue;
        };
        let Some(size) = camera.physical_viewport_size.filter(|s| s.x > 0 && s.y > 0) else {
            continue; // a zero-sized target renders nothing; keep the state for when it returns
        };
        alive.push(main.id());
        let settings = &rppm.settings;
        let key = ResourceKey {
            size,
            slots: settings.iterations_per_frame,
            shadow_resolution: settings.shadow_map_resolution,
            photon_capacity: photon_capacity(settings, scene, &device),
            importon_tiles: importon_tiles(settings, &scene.data),
            subsampling: settings.indirect_subsampling,
        };
        let fresh = || {
            ViewState::new(
                key,
                &device,
                &queue,
                &cache,
                &pipelines,
                &photon_pipelines,
                scene,
            )
        };
        let state = states.0.entry(main.id()).or_insert_with(fresh);
        if state.key != key {
            *state = fresh();
        }
        if state.scene_epoch != scene.epoch {
            state.rebind_scene(&device, &queue, &cache, &pipelines, scene);
        }
        if state.view_epoch != rppm.view_epoch {
            state.view_epoch = rppm.view_epoch;
            state.iteration = 0;
        }
        if state.iteration == 0 {
            state.radius2 = (settings.initial_radius_pixels as f64).powi(2);
        }
        if let Some(target) = rppm.fast_forward.filter(|&f| state.fast_forward != Some(f)) {
            state.fast_forward = Some(target);
            let initial = (settings.initial_radius_pixels as f64).powi(2);
            state.radius2 = radius2_after(initial, target, settings.alpha);
            state.iteration = target;
        }
        let estimate = matches!(
            settings.debug_view,
            RppmDebugView::None | RppmDebugView::DirectPhotons
        );
        state.photons = if key.photon_capacity > 0 && estimate {
            settings.photons_per_iteration
        } else {
            0
        };
        state.mode = settings.mode;
        state.debug_view = settings.debug_view;
        state.error = error.clone();
        state.importons = key.importon_tiles > 0 && settings.debug_view == RppmDebugView::None;
        let traces = state.photons > 0
            || state.importons
            || settings.debug_view == RppmDebugView::CubemapNormals;
        let cubemap = traces.then_some(CubemapConfig {
            resolution: settings.cubemap_resolution,
            tile_size: settings.cubemap_tile_size,
            bins: settings.bins,
        });
        let centre = view.world_from_view.translation();
        if let Err(e) = prepare_cubemap(
            state,
            cubemap,
            centre,
            &device,
            &queue,
            &cache,
            &cubemap_pipelines,
            scene,
        ) {
            state.error = Some(e);
        }
        // Importons need the cubemap bound; without one (its buffers refused) none are made.
        state.importons &= state.cubemap.is_some();
        select_stage_pipelines(state, scene, &cache, &mut pipelines, &mut photon_pipelines);
        state.output_pipeline = output_pipeline(
            &mut pipelines,
            &cache,
            settings.mode,
            camera,
            view_target,
            &mut warned_indirect,
        );
        let ready = match stages_ready(state, &cache) {
            Ok(view_ready) => ready && view_ready,
            Err(e) => {
                state.error = Some(e);
                false
            }
        };
        let base = state.iteration;
        let budget = settings
            .max_iterations
            .map_or(u32::MAX, |m| m.saturating_sub(base));
        let count = if ready {
            settings.iterations_per_frame.min(budget)
        } else {
            0
        };
        for slot in 0..count.max(1) {
            let mut params = iteration_params(view, camera, state, &scene.data, base + slot, slot);
            params.photons = state.photons;
            params.max_photon_depth = settings.max_photon_depth;
            params.photon_capacity = key.photon_capacity;
            params.source_count = scene.data.light_cdf.len() as u32;
            params.splat_radius = state.radius2.sqrt() as f32;
            params.max_eye_depth = settings.max_eye_depth;
            params.splat_russian_roulette = settings.splat_russian_roulette as u32;
            params.direct_photons = (settings.debug_view == RppmDebugView::DirectPhotons) as u32;
            params.indirect_only = (settings.mode == RppmMode::Indirect) as u32;
            params.kernel_flattening = settings.kernel_flattening;
            params.indirect_subsampling = settings.indirect_subsampling;
            if slot < count {
                state.radius2 = next_radius2(state.radius2, base + slot, settings.alpha);
            }
            queue.write_buffer(
                &state.params,
                slot as u64 * PARAMS_STRIDE,
                bytemuck::bytes_of(&params),
            );
            if slot < count && state.shadows.has_area {
                let eye = Vec4::from(params.area_position).truncate()
                    + Vec4::from(params.area_normal).truncate()
                        * scene.data.bounding_sphere().1
                        * 1e-4;
                let views = shadows::cube_views(eye, &scene.data, state.shadows.resolution);
                state.shadows.write_area_views(&queue, slot, &views);
            }
        }
        state.frame = (base, count);
        state.iteration += count;
        state.readback_pending = rppm.readback;
    }
    states.0.retain(|entity, _| alive.contains(entity));
}

/// The variants of the local-illumination and photon stages this view runs: only the
/// scattering paths its scene's materials have, importons only when camera paths go on.
fn select_stage_pipelines(
    state: &mut ViewState,
    scene: &SceneBuffers,
    cache: &PipelineCache,
    pipelines: &mut RppmPipelines,
    photon_pipelines: &mut PhotonPipelines,
) {
    state.local_pipeline = if state.importons {
        pipelines.local_importons.get(cache, &scene.specular_paths)
    } else {
        pipelines.local_illumination
    };
    let traced = state.photons > 0 && state.cubemap.is_some();
    state.photon_stages = Some(photon_pipelines.stage_ids(
        cache,
        traced.then_some(&scene.paths[..]),
        state.importons,
        state.key.subsampling > 1,
    ));
}

/// Makes, keeps or drops the view's deep cubemap, and centres it on the camera.
#[allow(clippy::too_many_arguments)]
fn prepare_cubemap(
    state: &mut ViewState,
    config: Option<CubemapConfig>,
    centre: Vec3,
    device: &RenderDevice,
    queue: &RenderQueue,
    cache: &PipelineCache,
    pipelines: &CubemapPipelines,
    scene: &SceneBuffers,
) -> Result<(), String> {
    let Some(config) = config else {
        state.cubemap = None;
        return Ok(());
    };
    let limits = device.limits();
    let limit = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    let fitted = config.fitted(limit, limits.max_texture_dimension_2d);
    if fitted != config {
        warn_once!(
            "bevy_rppm: a {}² deep cubemap with {} bins does not fit this GPU's buffers; \
             using {}²",
            config.resolution,
            config.bins,
            fitted.resolution
        );
    }
    let config = fitted;
    let capacity = state
        .cubemap_capacity
        .max(DeepCubemap::initial_capacity(
            config,
            scene.triangle_count(),
        ))
        .min((limit / 8) as u32);
    let stale = state
        .cubemap
        .as_ref()
        .is_none_or(|c| c.config != config || c.params.node_capacity < capacity);
    if stale {
        state.cubemap = None;
        state.cubemap = Some(DeepCubemap::new(
            device, queue, cache, pipelines, scene, config, centre, capacity,
        )?);
    }
    if let Some(cubemap) = &mut state.cubemap {
        cubemap.set_centre(queue, centre);
    }
    Ok(())
}

/// Pipelines the node records with, all compiled.
struct NodePipelines<'a> {
    cache: &'a PipelineCache,
    cubemap: &'a CubemapPipelines,
    shadow: &'a RenderPipeline,
    gbuffer: &'a RenderPipeline,
    local: &'a ComputePipeline,
    debug: Option<&'a ComputePipeline>,
    photon: Option<&'a ComputePipeline>,
    splat: Option<&'a RenderPipeline>,
    indirect_splat: Option<&'a ComputePipeline>,
    accumulate: &'a ComputePipeline,
}

/// The render-graph node: this frame's PPM iterations, then the view output.
#[allow(clippy::too_many_arguments)]
pub(crate) fn rppm_node(
    view: ViewQuery<(&MainEntity, &ViewTarget)>,
    scene: Option<Res<SceneBuffers>>,
    mut states: ResMut<RppmViews>,
    pipelines: Res<RppmPipelines>,
    cubemap_pipelines: Res<CubemapPipelines>,
    debug_pipelines: Res<DebugViewPipelines>,
    cache: Res<PipelineCache>,
    mut ctx: RenderContext,
) {
    let (main, view_target) = view.into_inner();
    let (Some(scene), Some(state)) = (scene, states.0.get_mut(&main.id())) else {
        return;
    };
    let Some(stages) = state.photon_stages else {
        return;
    };
    let (Some(shadow), Some(gbuffer), Some(local), Some(accumulate)) = (
        cache.get_render_pipeline(pipelines.shadow),
        cache.get_render_pipeline(pipelines.gbuffer),
        cache.get_compute_pipeline(state.local_pipeline),
        cache.get_compute_pipeline(stages.accumulate),
    ) else {
        return;
    };
    let photon = stages.trace.and_then(|id| cache.get_compute_pipeline(id));
    let splat = stages.splat.and_then(|id| cache.get_render_pipeline(id));
    let indirect_splat = stages
        .indirect_splat
        .and_then(|id| cache.get_compute_pipeline(id));
    let node = NodePipelines {
        cache: &cache,
        cubemap: &cubemap_pipelines,
        shadow,
        gbuffer,
        local,
        debug: debug_pipelines.get(&cache, state.debug_view),
        photon,
        splat,
        indirect_splat,
        accumulate,
    };
    let encoder = ctx.command_encoder();
    state.timer.begin_frame(state.frame.1);
    let (_, count) = state.frame;
    for slot in 0..count {
        let offset = (slot as u64 * PARAMS_STRIDE) as u32;
        if matches!(
            state.debug_view,
            RppmDebugView::None | RppmDebugView::DirectPhotons
        ) {
            encode_iteration(encoder, &node, state, &scene, slot, offset);
        } else {
            encode_debug_iteration(encoder, &node, state, &scene, offset);
        }
        encode_estimate(encoder, &node, state, offset);
    }
    let output = state
        .output_pipeline
        .and_then(|id| cache.get_render_pipeline(id));
    if let Some(output) = output {
        let mut pass = encoder.begin_render_pass(&RenderPassDescriptor {
            label: Some("rppm_output"),
            color_attachments: &[Some(RenderPassColorAttachment {
                view: view_target.main_texture_view(),
                depth_slice: None,
                resolve_target: None,
                ops: Operations {
                    load: LoadOp::Load,
                    store: StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: state.timer.render_pass(Stage::Output),
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(output);
        pass.set_bind_group(0, &state.output_group, &[0]);
        pass.draw(0..3, 0..1);
    }
    state.timer.end_frame(encoder);
}

/// One PPM iteration: shadow maps (light maps once per scene change, the area-light cube
/// every iteration), the G-buffer, local illumination.
fn encode_iteration(
    encoder: &mut CommandEncoder,
    node: &NodePipelines,
    state: &mut ViewState,
    scene: &SceneBuffers,
    slot: u32,
    offset: u32,
) {
    let triangles = scene.triangle_count();
    let mut layers: Vec<(u32, u32)> = Vec::new();
    if state.shadows.rendered_epoch != Some(scene.epoch) {
        layers.extend((0..state.shadows.light_layers).map(|l| (l, l)));
        state.shadows.rendered_epoch = Some(scene.epoch);
    }
    let maps = &state.shadows;
    if maps.has_area {
        let (views, layer) = (maps.area_view_base(slot), maps.light_layers);
        layers.extend((0..6).map(|f| (views + f, layer + f)));
    }
    shadows::render_layers(
        encoder,
        node.shadow,
        &state.scene_group,
        &state.shadows,
        triangles,
        layers.into_iter(),
        &mut state.timer,
    );
    encode_gbuffer(encoder, node.gbuffer, state, triangles, offset);
    build_cubemap(encoder, node, state);
    if state.importons {
        state.photon_targets.encode_importon_clear(encoder);
    }
    let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
        label: Some("rppm_local_illumination"),
        timestamp_writes: state.timer.compute_pass(Stage::LocalIllumination),
    });
    pass.set_pipeline(node.local);
    if let (true, Some(cubemap)) = (state.importons, &state.cubemap) {
        pass.set_bind_group(3, &cubemap.trace_group, &[]);
    }
    dispatch_per_pixel(&mut pass, state, offset);
    drop(pass);
    if let (true, Some(cubemap), Some(trace)) = (state.photons > 0, &state.cubemap, node.photon) {
        let groups = TracingGroups {
            scene: &state.scene_group,
            params: &state.params_group,
            offset,
            cubemap: &cubemap.trace_group,
        };
        state
            .photon_targets
            .encode_trace(encoder, trace, &groups, state.photons, &mut state.timer);
    }
}

/// Rebuilds the view's deep cubemap from the current triangles; false when it has none.
fn build_cubemap(
    encoder: &mut CommandEncoder,
    node: &NodePipelines,
    state: &mut ViewState,
) -> bool {
    let Some(cubemap) = &state.cubemap else {
        return false;
    };
    cubemap.encode_build(
        encoder,
        node.cache,
        node.cubemap,
        &state.scene_group,
        &mut state.timer,
    );
    true
}

/// Splats this iteration's photons (if any) and folds the sample into the estimate.
fn encode_estimate(
    encoder: &mut CommandEncoder,
    node: &NodePipelines,
    state: &mut ViewState,
    offset: u32,
) {
    let traced = traces_photons(state, node);
    let splat = if traced { node.splat } else { None };
    state.photon_targets.encode_splat(
        encoder,
        splat,
        &state.scene_group,
        offset,
        state.key.size,
        &mut state.timer,
    );
    if let (true, true, Some(cubemap), Some(indirect)) =
        (traced, state.importons, &state.cubemap, node.indirect_splat)
    {
        let groups = TracingGroups {
            scene: &state.scene_group,
            params: &state.params_group,
            offset,
            cubemap: &cubemap.trace_group,
        };
        state
            .photon_targets
            .encode_indirect_splat(encoder, indirect, &groups, &mut state.timer);
    }
    state.photon_targets.encode_accumulate(
        encoder,
        node.accumulate,
        &state.scene_group,
        state.key.size,
        offset,
        &mut state.timer,
    );
}

/// Whether this iteration traces photons: the scene emits, and the cubemap and pipeline exist.
fn traces_photons(state: &ViewState, node: &NodePipelines) -> bool {
    state.photons > 0 && state.cubemap.is_some() && node.photon.is_some()
}

/// Binds groups 0–2 of a per-pixel compute stage and dispatches it over the view.
fn dispatch_per_pixel(pass: &mut ComputePass, state: &ViewState, offset: u32) {
    pass.set_bind_group(0, &state.scene_group, &[]);
    pass.set_bind_group(1, &state.params_group, &[offset]);
    pass.set_bind_group(2, &state.local_group, &[]);
    let size = state.key.size;
    pass.dispatch_workgroups(size.x.div_ceil(8), size.y.div_ceil(8), 1);
}

/// One iteration of a debug image: the G-buffer's normals, or normals traced through a deep
/// cubemap built for this iteration.
fn encode_debug_iteration(
    encoder: &mut CommandEncoder,
    node: &NodePipelines,
    state: &mut ViewState,
    scene: &SceneBuffers,
    offset: u32,
) {
    let Some(debug) = node.debug else { return };
    let traced = state.debug_view == RppmDebugView::CubemapNormals;
    if traced {
        if !build_cubemap(encoder, node, state) {
            return;
        }
    } else {
        encode_gbuffer(encoder, node.gbuffer, state, scene.triangle_count(), offset);
    }
    let stage = if traced {
        Stage::CubemapTrace
    } else {
        Stage::LocalIllumination
    };
    let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
        label: Some("rppm_debug_view"),
        timestamp_writes: state.timer.compute_pass(stage),
    });
    pass.set_pipeline(debug);
    if let (true, Some(cubemap)) = (traced, &state.cubemap) {
        pass.set_bind_group(3, &cubemap.trace_group, &[]);
    }
    dispatch_per_pixel(&mut pass, state, offset);
}

fn encode_gbuffer(
    encoder: &mut CommandEncoder,
    pipeline: &RenderPipeline,
    state: &mut ViewState,
    triangles: u32,
    offset: u32,
) {
    let clear = Operations {
        load: LoadOp::Clear(LinearRgba::NONE.into()),
        store: StoreOp::Store,
    };
    let mut pass = encoder.begin_render_pass(&RenderPassDescriptor {
        label: Some("rppm_gbuffer"),
        color_attachments: &[
            Some(RenderPassColorAttachment {
                view: &state.gbuffer_position,
                depth_slice: None,
                resolve_target: None,
                ops: clear,
            }),
            Some(RenderPassColorAttachment {
                view: &state.gbuffer_normal,
                depth_slice: None,
                resolve_target: None,
                ops: clear,
            }),
        ],
        depth_stencil_attachment: Some(RenderPassDepthStencilAttachment {
            view: &state.gbuffer_depth,
            depth_ops: Some(Operations {
                load: LoadOp::Clear(0.0),
                store: StoreOp::Discard,
            }),
            stencil_ops: None,
        }),
        timestamp_writes: state.timer.render_pass(Stage::GBuffer),
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, &state.scene_group, &[]);
    pass.set_bind_group(1, &state.params_group, &[offset]);
    pass.draw(0..triangles * 3, 0..1);
}

/// The passes an iteration of this view runs, by the scene and settings (for the stats).
fn passes(state: &ViewState) -> Vec<String> {
    let debug = !matches!(
        state.debug_view,
        RppmDebugView::None | RppmDebugView::DirectPhotons
    );
    let traced = state.photons > 0 && state.cubemap.is_some();
    [
        (
            "shadow_maps",
            !debug && (state.shadows.light_layers > 0 || state.shadows.has_area),
        ),
        ("gbuffer", state.debug_view != RppmDebugView::CubemapNormals),
        ("cubemap_build", state.cubemap.is_some()),
        ("local_illumination", !debug),
        ("importon_tracing", state.importons),
        ("photon_trace", traced),
        ("splat", traced),
        ("indirect_splat", traced && state.importons),
        ("debug_view", debug),
        ("accumulate", true),
        ("output", state.output_pipeline.is_some()),
    ]
    .into_iter()
    .filter(|(_, runs)| *runs)
    .map(|(name, _)| name.to_string())
    .collect()
}

/// After submission: read back what was asked for and report each view to the main world.
pub(crate) fn report_views(
    mut states: ResMut<RppmViews>,
    scene: Option<Res<SceneBuffers>>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    adapter: Res<RenderAdapterInfo>,
    sender: Res<RenderSender>,
) {
    let scene_epoch = scene.as_ref().map_or(0, |s| s.epoch);
    let scene_paths: Vec<String> = scene
        .as_ref()
        .map(|s| s.paths.iter().map(|p| p.to_string()).collect())
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
    for (entity, state) in states.0.iter_mut() {
        state.timer.start_readback();
        // A read-back frame waits for the GPU anyway; others only look.
        let waiting = state.readback_pending;
        state.timer.collect(&device, waiting);
        if state.readback_pending
            && let Some(bytes) = read_back(&device, &queue, &state.radiance)
        {
            let pixels = bytemuck::cast_slice(&bytes).to_vec();
            let _ = sender.send(RenderMessage::Radiance(RadianceImage {
                camera: *entity,
                width: state.key.size.x,
                height: state.key.size.y,
                iteration: state.iteration,
                epoch: scene_epoch.wrapping_add(state.view_epoch),
                pixels,
            }));
        }
        if state.readback_pending
            && let Some(count) = state.photon_targets.photon_count()
            && let Some(bytes) = read_back(&device, &queue, count)
        {
            state.photons_stored = bytemuck::cast_slice::<u8, u32>(&bytes)[1];
        }
        if state.readback_pending
            && state.importons
            && let Some(bytes) = read_back(&device, &queue, &state.photon_targets.importon_stats)
        {
            state.importons_made = bytemuck::cast_slice::<u8, u32>(&bytes)[1];
        }
        let mut memory = scene_memory.clone();
        memory.extend(state.memory());
        if let Some(cubemap) = &state.cubemap {
            // Frames that wait for the GPU anyway read this build's counters; others take an
            // earlier build's when its non-blocking read-back arrives.
            let counters = if state.readback_pending {
                read_back(&device, &queue, cubemap.counters()).map(|bytes| {
                    let c: &[u32] = bytemuck::cast_slice(&bytes);
                    [c[0], c[1]]
                })
            } else {
                cubemap.poll_counters(&device)
            };
            if let Some([used, lost]) = counters {
                state.cubemap_nodes = (used.min(cubemap.params.node_capacity), lost);
                if lost > 0 {
                    state.cubemap_capacity = (used as u64 * 5 / 4).min(u32::MAX as u64 / 2) as u32;
                }
            }
        }
        let _ = sender.send(RenderMessage::Stats(
            *entity,
            ViewStats {
                epoch: scene_epoch.wrapping_add(state.view_epoch),
                iteration: state.iteration,
                iterations_this_frame: state.frame.1,
                gpu_timing: state.timer.supported(),
                stage_ms: Stage::ALL
                    .iter()
                    .map(|s| s.name().to_string())
                    .zip(state.timer.last_ms)
                    .collect(),
                stage_ms_total: Stage::ALL
                    .iter()
                    .map(|s| s.name().to_string())
                    .zip(state.timer.total_ms)
                    .collect(),
                timed_iterations: state.timer.timed_iterations,
                memory: memory.into_iter().collect(),
                adapter: adapter.name.clone(),
                error: state.error.clone(),
                cubemap_nodes: state.cubemap_nodes.0,
                photons_per_iteration: state.photons,
                photons_stored: state.photons_stored,
                importons: state.importons_made,
                passes: passes(state),
                splat_radius_pixels: state.radius2.sqrt(),
                shader_paths: scene_paths.clone(),
                cubemap_overflow: state.cubemap_nodes.1,
            },
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// r² after n steps behaves as r₀² n^(α−1) / Γ(1+α): the ratio between two far points of
    /// the sequence is (n₂/n₁)^(α−1), with no underflow, NaN or growth on the way.
    #[test]
    fn radius_decay_stays_finite_and_follows_its_power_law_over_1e8_iterations() {
        for alpha in [1e-4_f32, 0.01, 0.7, 0.999, 1.0] {
            let r2_6 = radius2_after(16.0, 1_000_000, alpha);
            let r2_8 = (1_000_000..100_000_000).fold(r2_6, |r2, i| next_radius2(r2, i, alpha));
            for r2 in [r2_6, r2_8] {
                assert!(
                    r2.is_finite() && r2 > 0.0 && r2 <= 16.0,
                    "α {alpha}: r² {r2}"
                );
            }
            let expected = 100f64.powf(alpha as f64 - 1.0);
            let ratio = r2_8 / r2_6;
            assert!(
                (ratio / expected - 1.0).abs() < 1e-4,
                "α {alpha}: r² ratio {ratio} vs {expected}"
            );
        }
    }

    #[test]
    fn radius_keeps_its_size_at_alpha_one() {
        assert_eq!(radius2_after(16.0, 1000, 1.0), 16.0);
        assert_eq!(radius2_after(16.0, 0, 0.7), 16.0);
    }
}
