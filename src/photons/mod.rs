//! Photon tracing: photons leave the lights by power, are traced through the deep cubemap,
//! stored at non-specular hits after their first bounce and scattered or absorbed by Russian
//! roulette (`shaders/photons/trace.wgsl`). The pipeline is specialized by the scene's
//! scattering paths.

mod budget;

use bevy::prelude::*;
use bevy::render::render_resource::binding_types::storage_buffer_sized;
use bevy::render::render_resource::*;
use bevy::render::renderer::RenderDevice;
use bevy::render::{RenderApp, RenderStartup};

use crate::cubemap::{TracingGroups, tracing_pipeline};
use crate::ppm::photon_store_capacity;
use crate::scene::{ScatterPaths, SceneBuffers, texture_defs};
use crate::settings::{PhotonCount, PhotonMapping, RppmDebugView};
use crate::shaders::RppmShaders;
use crate::stats::timing::{Stage, StageTimer};
use crate::view::ViewLayouts;

pub use budget::{FrameCost, MIN_PHOTONS, PhotonController, START_PHOTONS};

/// Bytes of one stored photon (`Photon` in common.wgsl).
pub const PHOTON_BYTES: u64 = 64;

/// Photons a view's store must hold for `photons` a iteration (see
/// [`photon_store_capacity`]), capped by the GPU's largest storage binding; 0 when nothing
/// emits or no photon can be stored.
pub(crate) fn store_capacity(
    settings: &PhotonMapping,
    photons: u32,
    scene: &SceneBuffers,
    device: &RenderDevice,
) -> u32 {
    let direct = settings.debug_view == RppmDebugView::DirectPhotons;
    let stores = if direct {
        1
    } else {
        settings.max_photon_depth - 1
    };
    if scene.data.light_cdf.is_empty() || photons == 0 || stores == 0 {
        return 0;
    }
    let wanted = photon_store_capacity(photons, stores, scene.max_scatter, direct);
    let limit = device.limits().max_storage_buffer_binding_size / PHOTON_BYTES;
    // The indirect splat dispatches one thread per stored photon, in one dimension.
    (wanted.ceil() as u64)
        .min(limit)
        .min(dispatch_limit(device) as u64) as u32
}

/// The most threads one dimension of a 64-wide compute dispatch can have on this device.
fn dispatch_limit(device: &RenderDevice) -> u32 {
    device
        .limits()
        .max_compute_workgroups_per_dimension
        .saturating_mul(64)
}

/// The photon setting with its counts at most what one dispatch of the device can trace
/// (4 194 240 on most), with one warning when that cuts it.
pub(crate) fn device_photon_count(setting: PhotonCount, device: &RenderDevice) -> PhotonCount {
    let limit = dispatch_limit(device);
    let capped = match setting {
        PhotonCount::Fixed(n) => PhotonCount::Fixed(n.min(limit)),
        PhotonCount::Auto { max } => PhotonCount::Auto {
            max: max.min(limit),
        },
        PhotonCount::GpuMilliseconds { milliseconds, max } => PhotonCount::GpuMilliseconds {
            milliseconds,
            max: max.min(limit),
        },
    };
    if capped != setting {
        warn_once!(
            "bevy_rppm: {setting:?} photons per iteration is more than one dispatch of this GPU traces; using at most {limit}"
        );
    }
    capped
}

pub(crate) struct PhotonsPlugin;

impl Plugin for PhotonsPlugin {
    fn build(&self, app: &mut App) {
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app
                .init_resource::<SpecializedComputePipelines<PhotonPipeline>>()
                .add_systems(RenderStartup, init_photon_pipeline);
        }
    }
}

/// The photon-tracing stage, specialized by [`PhotonKey`].
#[derive(Resource)]
pub struct PhotonPipeline {
    /// 0 the photon store, 1 its count (draw-indirect arguments).
    pub store_layout: BindGroupLayoutDescriptor,
    base: ComputePipelineDescriptor,
}

/// Which photon-tracing variant a scene runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PhotonKey {
    /// The scattering lobes of the scene's materials.
    pub paths: ScatterPaths,
    /// The scene's texture lookups (`TEXTURED`).
    pub textured: bool,
    /// Rays through the hierarchy (`BVH`): `RppmTracer::Bvh`.
    pub bvh: bool,
}

impl SpecializedComputePipeline for PhotonPipeline {
    type Key = PhotonKey;

    fn specialize(&self, key: PhotonKey) -> ComputePipelineDescriptor {
        let mut descriptor = self.base.clone();
        descriptor.shader_defs = key
            .paths
            .shader_defs()
            .into_iter()
            .map(Into::into)
            .collect();
        descriptor.shader_defs.extend(texture_defs(key.textured));
        if key.bvh {
            descriptor.shader_defs.push("BVH".into());
        }
        descriptor
    }
}

fn init_photon_pipeline(
    mut commands: Commands,
    shaders: Res<RppmShaders>,
    layouts: Res<ViewLayouts>,
) {
    let store_layout = BindGroupLayoutDescriptor::new(
        "rppm_photon_store_layout",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                storage_buffer_sized(false, None),
                storage_buffer_sized(false, None),
            ),
        ),
    );
    let base = tracing_pipeline(
        "rppm_photon_trace",
        &layouts,
        &store_layout,
        &shaders.photon_trace,
    );
    commands.insert_resource(PhotonPipeline { store_layout, base });
}

/// One camera's photon store, when the scene has lights to emit from.
pub struct PhotonStore {
    pub photons: Buffer,
    /// Draw-indirect arguments whose instance count is the number of photons stored.
    pub count: Buffer,
    group: BindGroup,
}

impl PhotonStore {
    /// Room for `capacity` photons.
    pub fn new(
        device: &RenderDevice,
        cache: &PipelineCache,
        pipeline: &PhotonPipeline,
        capacity: u32,
    ) -> Self {
        let photons = device.create_buffer(&BufferDescriptor {
            label: Some("rppm_photons"),
            size: capacity as u64 * PHOTON_BYTES,
            usage: BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let count = device.create_buffer_with_data(&BufferInitDescriptor {
            label: Some("rppm_photon_count"),
            contents: bytemuck::cast_slice(&[6u32, 0, 0, 0]),
            usage: BufferUsages::STORAGE
                | BufferUsages::INDIRECT
                | BufferUsages::COPY_DST
                | BufferUsages::COPY_SRC,
        });
        let group = device.create_bind_group(
            "rppm_photon_store_group",
            &cache.get_bind_group_layout(&pipeline.store_layout),
            &BindGroupEntries::sequential((photons.as_entire_binding(), count.as_entire_binding())),
        );
        Self {
            photons,
            count,
            group,
        }
    }

    /// Photon tracing for one iteration.
    pub fn encode_trace(
        &self,
        encoder: &mut CommandEncoder,
        pipeline: &ComputePipeline,
        groups: &TracingGroups,
        photons: u32,
        timer: &mut StageTimer,
    ) {
        encoder.clear_buffer(&self.count, 4, Some(4));
        let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
            label: Some("rppm_photon_trace"),
            timestamp_writes: timer.compute_pass(Stage::PhotonTrace),
        });
        groups.bind(&mut pass, pipeline, &self.group);
        pass.dispatch_workgroups(photons.div_ceil(64), 1, 1);
    }
}
