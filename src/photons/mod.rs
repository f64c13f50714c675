//! Photon tracing: photons leave the lights by power, are traced through the deep cubemap,
//! stored at non-specular hits after their first bounce and scattered or absorbed by Russian
//! roulette (`shaders/photons/trace.wgsl`), then sorted by cubemap tile into the photon map
//! that both splats gather from (`map.rs`). Tracing is specialized by the scene's scattering
//! paths.

mod budget;
#[cfg(test)]
pub(crate) mod ellipse;
mod map;
mod store;

use bevy::prelude::*;
use bevy::render::render_resource::binding_types::storage_buffer_sized;
use bevy::render::render_resource::*;
use bevy::render::renderer::RenderDevice;
use bevy::render::{RenderApp, RenderStartup};

use crate::cubemap::tracing_pipeline;
use crate::scene::{Lookups, ScatterPaths, texture_defs};
use crate::settings::PhotonCount;
use crate::shaders::RppmShaders;
use crate::view::ViewLayouts;

pub use budget::{FrameCost, MIN_PHOTONS, PhotonController, START_PHOTONS};
#[cfg(test)]
pub(crate) use map::SCAN_BLOCK;
pub use map::{PhotonMap, SortPipelines};
pub(crate) use store::store_capacity;
pub use store::{PHOTON_BYTES, PhotonStore, StoreFit};

/// The most threads one dimension of a 64-wide compute dispatch can have on this device.
pub(crate) fn dispatch_limit(device: &RenderDevice) -> u32 {
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

/// Photons one tracing invocation takes in turn (photons/trace.wgsl starts the next when one
/// ends): 8 on a software adapter, whose 8-lane SIMD groups otherwise idle behind their
/// longest path (photon trace 10-15 % faster on llvmpipe), 1 on a GPU, which wants every
/// photon a thread for occupancy (not measured on one with more).
pub fn photons_per_lane(software: bool) -> u32 {
    if software { 8 } else { 1 }
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

/// The photon-tracing stage, specialized by [`PhotonKey`], and the sort into the photon map.
#[derive(Resource)]
pub struct PhotonPipeline {
    /// 0 the photons as stored, 1 their count, 2 per cubemap tile, the photons stored in it,
    /// 3 per photon, its tile and its rank among the tile's photons.
    pub store_layout: BindGroupLayoutDescriptor,
    base: ComputePipelineDescriptor,
    pub sort: SortPipelines,
}

/// An iteration's photon passes, compiled: tracing and the sort's passes.
pub struct PhotonPasses<'a> {
    pub trace: &'a ComputePipeline,
    pub sort: [&'a ComputePipeline; 4],
}

/// Which photon-tracing variant a scene runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PhotonKey {
    /// The scattering lobes of the scene's materials.
    pub paths: ScatterPaths,
    /// The scene's material lookups.
    pub lookups: Lookups,
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
        descriptor.shader_defs.extend(texture_defs(key.lookups));
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
    cache: Res<PipelineCache>,
) {
    let store_layout = BindGroupLayoutDescriptor::new(
        "rppm_photon_store_layout",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                storage_buffer_sized(false, None),
                storage_buffer_sized(false, None),
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
    commands.insert_resource(PhotonPipeline {
        store_layout,
        base,
        sort: SortPipelines::new(&cache, &shaders),
    });
}
