//! One camera's photon-mapping state, a component of its render-world view entity: each
//! stage's resources, the iteration counter a change resets, and the variants it runs.

use bevy::prelude::*;
use bevy::render::render_resource::*;
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bevy::render::texture::TextureCache;

use super::pace::IterationController;
use crate::accumulate::{AccumulatePipeline, Estimate, EstimateInputs, HistoryClock};
use crate::cubemap::ViewCubemap;
use crate::gbuffer::GBuffer;
use crate::importons::{EyePathPipeline, EyePaths};
use crate::indirect_splat::{self, IndirectSplatPipeline};
use crate::output::{OutputGroups, OutputPipeline};
use crate::photons::{PhotonController, PhotonPipeline, PhotonStore, StoreFit};
use crate::scene::SceneBuffers;
use crate::settings::{RppmDebugView, RppmMode};
use crate::shadows::ShadowMaps;
use crate::splat::{SplatInputs, SplatPipeline, SplatTarget, kernel_stats};
use crate::stats::profile::WallProfile;
use crate::stats::timing::StageTimer;
use crate::view::params::{SEEN_REGION_BYTES, params_binding};
use crate::view::{PARAMS_STRIDE, ViewLayouts};

/// What forces the view's GPU resources to be made anew.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct ResourceKey {
    pub size: UVec2,
    pub slots: u32,
    pub shadow_resolution: u32,
    /// Room for stored photons; 0 without lights.
    pub photon_capacity: u32,
    /// Camera paths go past the G-buffer: importons are held.
    pub importons: bool,
    /// Importon slots past the image's own, for rough glass's camera paths.
    pub extra_importons: u32,
    /// Tiles of the photon map (the cubemap's).
    pub photon_tiles: u32,
    /// Photons splat on every n-th pixel (the splat target's size follows).
    pub subsampling: u32,
    /// History is kept through motion (`RppmHistory::Reuse`): its buffers are held.
    pub history: bool,
    /// Rays go through the view's hierarchy (`RppmTracer::Bvh`), not the deep cubemap.
    pub bvh: bool,
    /// The scene has textures: each pixel's resolved surface is held for the splat.
    pub textured: bool,
    /// Photons each tracing invocation takes in turn ([`crate::photons::photons_per_lane`]).
    pub photons_per_lane: u32,
    /// Each pixel's kernels adapt (`PhotonMapping::adaptive_kernel`, photons gathered at every
    /// pixel): their statistics are held, its importon's too where importons are made.
    pub adaptive_kernel: bool,
}

/// The pipelines a view's iteration runs, by its scene and settings.
#[derive(Clone, Copy, Debug)]
pub struct StageIds {
    pub gbuffer: CachedRenderPipelineId,
    pub eye_paths: CachedComputePipelineId,
    pub trace: Option<CachedComputePipelineId>,
    /// The photon sort's passes, with tracing.
    pub sort: Option<[CachedComputePipelineId; 4]>,
    pub splat: Option<CachedComputePipelineId>,
    pub indirect_splat: Option<CachedComputePipelineId>,
    pub accumulate: CachedComputePipelineId,
    /// Edges resolved after a camera move, under `Reuse` with rays to trace.
    pub resolve: Option<CachedComputePipelineId>,
    /// The outlier passes, where camera paths go on.
    pub outliers: Option<[CachedComputePipelineId; 2]>,
    pub output: Option<CachedRenderPipelineId>,
}

/// A camera's PPM state, on its render-world view entity.
#[derive(Component)]
pub struct RppmViewState {
    pub key: ResourceKey,
    pub view_epoch: u64,
    pub view_moves: u64,
    /// Iterations since the last reset, and what the next does with history.
    pub clock: HistoryClock,
    /// The scene changed since the last frame (its resources are bound anew).
    pub scene_changed: bool,
    /// ... and its light may have changed, not only its objects' places.
    pub scene_relit: bool,
    /// ... and changed its shape (counts of triangles, materials, lights or emitters): an
    /// object or light came or went, so history is not kept.
    pub scene_reshaped: bool,
    scene_shape: [usize; 4],
    /// Where last frame's iterations looked from (unjittered clip_from_world).
    pub previous_clip_from_world: Mat4,
    /// This frame's first iteration reprojects last frame's history.
    pub reprojects: bool,
    /// The share of resolved edges in what this frame shows (`accumulate::resolve_share`).
    pub resolve_share: f32,
    /// Iterations since the last frame whose camera moved, if any since the estimate started.
    pub since_move: Option<u32>,
    /// Some iteration of this frame clamps history to its neighbourhoods, which read last
    /// iteration's copy of the pixels' means since the change (`HistoryFlags::clamps`).
    pub clamps: bool,
    /// First iteration and count run this frame.
    pub frame: (u32, u32),
    /// Squared gather radius in pixels for the next iteration (Knaus–Zwicker sequence).
    pub radius2: f64,
    /// The photons per iteration `radius2`'s sequence is sized for (0 before the first frame).
    pub radius_photons: u32,
    /// The next iteration is the first of a radius sequence after a restart or a camera move
    /// (its pixels' kernel statistics start again).
    pub radius_restart: bool,
    /// This frame's first iteration begins a radius sequence: the importons' kernel
    /// statistics are cleared before it (no indirect splat runs where none is made).
    pub kernels_restart: bool,
    /// The last `RppmFastForward` applied.
    pub fast_forward: Option<u32>,
    /// Photons emitted per iteration this frame (0: no photon passes).
    pub photons: u32,
    /// Where the photon count's controller stands.
    pub photon_count: PhotonController,
    /// Where the iterations-per-frame controller stands.
    pub iterations: IterationController,
    /// The stores counted, which size the photon store.
    pub store_fit: StoreFit,
    /// When the view's last frame was reported (its interval times an iteration).
    pub last_report: Option<std::time::Instant>,
    /// Whether camera paths go past the G-buffer this frame (importon tracing and indirect
    /// splatting).
    pub importons: bool,
    /// Whether shadows are rays through the deep cubemap (whenever the view has one) rather
    /// than shadow maps, which are then not rendered.
    pub traced_shadows: bool,
    /// Photons stored, and importons made, by the last iteration read back.
    pub photons_stored: u32,
    pub importons_made: u32,
    pub mode: RppmMode,
    pub debug_view: RppmDebugView,
    /// Each stage submitted alone and timed by the wall clock (`profile_stages`).
    pub profile: bool,
    pub stages: Option<StageIds>,
    pub cubemap: ViewCubemap,
    pub shadows: ShadowMaps,
    pub gbuffer: GBuffer,
    pub eye_paths: EyePaths,
    pub store: Option<PhotonStore>,
    pub splats: SplatTarget,
    pub kernel_stats: Buffer,
    pub importon_kernel_stats: Buffer,
    pub indirect_group: Option<BindGroup>,
    pub estimate: Estimate,
    pub params: Buffer,
    /// How far the camera sees, counted each iteration (`SEEN_REGION_BYTES`).
    pub seen_region: Buffer,
    pub scene_group: BindGroup,
    pub params_group: BindGroup,
    pub output_group: OutputGroups,
    pub readback_pending: bool,
    /// Scene epoch the scene-dependent resources (shadow maps, bind groups) were made for.
    pub scene_epoch: u64,
    pub error: Option<String>,
}

/// GPU time per stage of a view: the one thing the render-graph system writes while
/// recording.
#[derive(Component)]
pub struct ViewTimer(pub StageTimer, pub WallProfile);

/// The pipelines whose layouts a view's resources are bound with.
pub struct StagePipelines<'a> {
    pub layouts: &'a ViewLayouts,
    pub eye_paths: &'a EyePathPipeline,
    pub photons: &'a PhotonPipeline,
    pub splat: &'a SplatPipeline,
    pub indirect_splat: &'a IndirectSplatPipeline,
    pub accumulate: &'a AccumulatePipeline,
    pub output: &'a OutputPipeline,
}

impl RppmViewState {
    /// What a state made anew for the view keeps: the controllers and the store's counts.
    pub fn kept(&self) -> (PhotonController, IterationController, StoreFit, u32) {
        let (photons, store) = (self.photon_count, self.store_fit);
        (photons, self.iterations, store, self.key.photon_capacity)
    }

    /// Whether this frame resolves edges, so shows `shown` rather than the estimate itself.
    pub fn resolves(&self) -> bool {
        self.resolve_share > 0.0
    }

    /// Invocations that trace this frame's photons, each taking `photons_per_lane` in turn.
    pub fn photon_lanes(&self) -> u32 {
        self.photons.div_ceil(self.key.photons_per_lane)
    }

    /// Every resource of a view with `key`, its targets taken from `textures` for this frame.
    pub fn new(
        key: ResourceKey,
        device: &RenderDevice,
        queue: &RenderQueue,
        cache: &PipelineCache,
        textures: &mut TextureCache,
        pipelines: &StagePipelines,
        scene: &SceneBuffers,
    ) -> Self {
        let size = key.size;
        let gbuffer = GBuffer::new(textures, device, size);
        let params = device.create_buffer(&BufferDescriptor {
            label: Some("rppm_iteration_params"),
            size: key.slots as u64 * PARAMS_STRIDE,
            usage: BufferUsages::UNIFORM | BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let eye_paths = EyePaths::new(
            device,
            size,
            key.importons,
            key.extra_importons,
            key.textured,
        );
        let splats = SplatTarget::new(textures, device, size, key.subsampling);
        let kept = key.adaptive_kernel && key.importons;
        let importon_kernel_stats = kernel_stats(device, size, kept, "rppm_importon_kernel_stats");
        let kernel_stats = kernel_stats(device, size, key.adaptive_kernel, "rppm_kernel_stats");
        let estimate = Estimate::new(device, size, key.history, key.importons, key.textured);
        let (store, indirect_group) = photon_store(
            key,
            device,
            cache,
            pipelines,
            &eye_paths,
            &importon_kernel_stats,
        );
        let seen_region = device.create_buffer(&BufferDescriptor {
            label: Some("rppm_seen_region"),
            size: SEEN_REGION_BYTES,
            usage: BufferUsages::STORAGE | BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let params_group = device.create_bind_group(
            "rppm_params_group",
            &cache.get_bind_group_layout(&pipelines.layouts.params),
            &BindGroupEntries::sequential((
                params_binding(&params),
                seen_region.as_entire_binding(),
            )),
        );
        let output_group = OutputGroups::new(
            device,
            cache,
            pipelines.output,
            params_binding(&params),
            &estimate.radiance,
            estimate.resolved.as_ref().map(|r| &r.shown),
        );
        let shadows = ShadowMaps::new(device, &scene.data, key.shadow_resolution, key.slots, false);
        shadows.write_light_views(queue, &scene.data);
        let scene_group = scene.bind_group(device, cache, &pipelines.layouts.scene, &shadows.views);
        let mut state = Self {
            key,
            view_epoch: u64::MAX,
            view_moves: u64::MAX,
            clock: HistoryClock::default(),
            scene_changed: false,
            scene_relit: false,
            scene_reshaped: false,
            scene_shape: scene.data.shape(),
            previous_clip_from_world: Mat4::IDENTITY,
            reprojects: false,
            resolve_share: 0.0,
            since_move: None,
            clamps: false,
            frame: (0, 0),
            radius2: 0.0,
            radius_photons: 0,
            radius_restart: true,
            kernels_restart: false,
            fast_forward: None,
            photons: 0,
            photon_count: PhotonController::default(),
            iterations: IterationController::default(),
            store_fit: StoreFit::default(),
            last_report: None,
            importons: false,
            traced_shadows: false,
            photons_stored: 0,
            importons_made: 0,
            mode: RppmMode::Full,
            debug_view: RppmDebugView::None,
            profile: false,
            stages: None,
            cubemap: ViewCubemap::default(),
            shadows,
            gbuffer,
            eye_paths,
            store,
            splats,
            kernel_stats,
            importon_kernel_stats,
            indirect_group,
            estimate,
            params,
            seen_region,
            scene_group,
            params_group,
            output_group,
            readback_pending: false,
            scene_epoch: scene.epoch,
            error: None,
        };
        state.bind_targets(device, cache, pipelines);
        state
    }

    /// Takes this frame's G-buffer and splat target from the texture cache (the same textures
    /// while the view keeps its size and they are asked for every frame), and binds them when
    /// they changed.
    pub fn refresh_targets(
        &mut self,
        device: &RenderDevice,
        cache: &PipelineCache,
        textures: &mut TextureCache,
        pipelines: &StagePipelines,
    ) {
        let size = self.key.size;
        let gbuffer = GBuffer::new(textures, device, size);
        let splats = SplatTarget::new(textures, device, size, self.key.subsampling);
        // The cache hands back last frame's textures while nothing else took them: then the
        // groups that hold them stay as they are.
        if gbuffer.same_textures(&self.gbuffer) && splats.view.id() == self.splats.view.id() {
            return;
        }
        self.gbuffer = gbuffer;
        self.splats = splats;
        self.bind_targets(device, cache, pipelines);
    }

    /// Makes the history's copies of last frame (`RppmHistory::Reuse`, when an iteration
    /// first reads them: a still view reads none) and binds them; they stay.
    pub fn keep_previous(
        &mut self,
        device: &RenderDevice,
        cache: &PipelineCache,
        pipelines: &StagePipelines,
    ) {
        let made = self
            .estimate
            .history
            .as_mut()
            .is_some_and(|h| h.make_previous(device));
        if made {
            self.bind_targets(device, cache, pipelines);
        }
    }

    /// The groups that hold the targets: eye paths, splats, accumulation.
    fn bind_targets(
        &mut self,
        device: &RenderDevice,
        cache: &PipelineCache,
        pipelines: &StagePipelines,
    ) {
        self.eye_paths.bind(
            device,
            cache,
            pipelines.eye_paths,
            &self.gbuffer,
            &self.shadows,
        );
        let params = params_binding(&self.params);
        if let Some(store) = &self.store {
            self.splats.bind(
                device,
                cache,
                pipelines.splat,
                SplatInputs {
                    store,
                    gbuffer: &self.gbuffer,
                    surfaces: &self.eye_paths.surfaces,
                    kernel_stats: &self.kernel_stats,
                },
            );
        }
        self.estimate.bind(
            device,
            cache,
            pipelines.accumulate,
            EstimateInputs {
                params,
                eye_paths: &self.eye_paths,
                splats: &self.splats,
                gbuffer: &self.gbuffer,
            },
        );
    }

    /// A changed scene keeps the view's targets: only what depends on the scene's lights and
    /// buffers is made again; the frame then restarts or keeps the estimate.
    pub fn rebind_scene(
        &mut self,
        device: &RenderDevice,
        queue: &RenderQueue,
        cache: &PipelineCache,
        pipelines: &StagePipelines,
        scene: &SceneBuffers,
    ) {
        self.shadows = ShadowMaps::new(
            device,
            &scene.data,
            self.key.shadow_resolution,
            self.key.slots,
            self.shadows.mapped,
        );
        self.shadows.write_light_views(queue, &scene.data);
        self.scene_group =
            scene.bind_group(device, cache, &pipelines.layouts.scene, &self.shadows.views);
        self.bind_targets(device, cache, pipelines);
        if let Some(cubemap) = &mut self.cubemap.cubemap {
            cubemap.set_scene(queue, scene);
        }
        self.scene_epoch = scene.epoch;
        self.scene_changed = true;
        self.scene_relit |= scene.relit;
        let shape = scene.data.shape();
        self.scene_reshaped |= shape != self.scene_shape;
        self.scene_shape = shape;
    }

    /// A new photon count keeps the estimate: only the store and the groups that hold it
    /// are made again.
    pub fn resize_store(
        &mut self,
        capacity: u32,
        device: &RenderDevice,
        cache: &PipelineCache,
        pipelines: &StagePipelines,
    ) {
        self.key.photon_capacity = capacity;
        let stats = &self.importon_kernel_stats;
        (self.store, self.indirect_group) =
            photon_store(self.key, device, cache, pipelines, &self.eye_paths, stats);
        self.bind_targets(device, cache, pipelines);
    }

    /// Bytes held per buffer or texture of the view.
    pub fn memory(&self) -> Vec<(String, u64)> {
        let pixels = self.key.size.x as u64 * self.key.size.y as u64;
        let mut memory: Vec<(&str, u64)> = self.eye_paths.memory().to_vec();
        memory.push(("splats", self.splats.bytes()));
        memory.push(("kernel_stats", self.kernel_stats.size()));
        memory.push(("importon_kernel_stats", self.importon_kernel_stats.size()));
        if let Some(store) = &self.store {
            memory.push(("photons", store.stored.size()));
            memory.push(("photon_tiles", store.tiles.size()));
            memory.push(("photon_map", store.map.bytes()));
        }
        memory.extend([
            ("gbuffer", GBuffer::bytes(pixels)),
            ("radiance", self.estimate.radiance.size()),
            ("iteration_params", self.params.size()),
            ("shadow_maps", self.shadows.bytes()),
            ("timestamps", 4096 * 8 * 2),
        ]);
        memory.extend(self.estimate.memory());
        if let Some(cubemap) = &self.cubemap.cubemap {
            memory.extend(cubemap.memory());
        }
        if let Some(bvh) = &self.cubemap.bvh {
            memory.push(("bvh", bvh.buffers.bytes));
        }
        memory
            .into_iter()
            .map(|(n, b)| (n.to_string(), b))
            .collect()
    }
}

/// The photon store of `key`'s capacity (none at 0), and the indirect splat's group on it.
fn photon_store(
    key: ResourceKey,
    device: &RenderDevice,
    cache: &PipelineCache,
    pipelines: &StagePipelines,
    eye_paths: &EyePaths,
    kernel_stats: &Buffer,
) -> (Option<PhotonStore>, Option<BindGroup>) {
    let store = (key.photon_capacity > 0).then(|| {
        PhotonStore::new(
            device,
            cache,
            pipelines.photons,
            key.photon_capacity,
            key.photon_tiles,
        )
    });
    let group = store.as_ref().filter(|_| key.importons).map(|store| {
        let pipeline = pipelines.indirect_splat;
        indirect_splat::bind_group(device, cache, pipeline, store, eye_paths, kernel_stats)
    });
    (store, group)
}
