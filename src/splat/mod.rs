//! Direct splatting, as a gather: each pixel's G-buffer point visits the deep-cubemap tiles
//! its gather radius reaches, a run of the photon map per row of tiles, and adds
//! f·Φ/(πr²) for each inside its kernel (a disc of the gather radius on the pixel's surface,
//! flattened along its normal). Subsampled (ISPM), one pixel of every n×n block gathers
//! incident light, upsampled in accumulation (`shaders/splat/splat.wgsl`).
//!
//! It was a quad rasterised per photon, summed by blending: on llvmpipe the quads' set-up and
//! fragments cost more than tracing the photons, and the per-pixel gather walks the same
//! photons once, with the pixel's material looked up once.

use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{
    storage_buffer_read_only_sized, storage_buffer_sized, texture_2d, texture_storage_2d,
};
use bevy::render::render_resource::*;
use bevy::render::renderer::RenderDevice;
use bevy::render::texture::TextureCache;
use bevy::render::{RenderApp, RenderStartup};

use crate::cubemap::{TracingGroups, tracing_pipeline};
use crate::gbuffer::{GBuffer, target};
use crate::photons::PhotonStore;
use crate::scene::{Lookups, ScatterPaths, material_defs};
use crate::shaders::RppmShaders;
use crate::stats::timing::{Stage, StageTimer};
use crate::view::ViewLayouts;

pub(crate) struct SplatPlugin;

impl Plugin for SplatPlugin {
    fn build(&self, app: &mut App) {
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app
                .init_resource::<SpecializedComputePipelines<SplatPipeline>>()
                .add_systems(RenderStartup, init_splat_pipeline);
        }
    }
}

/// The per-iteration splat sums, written once per texel (no blending).
const SPLAT_FORMAT: TextureFormat = TextureFormat::Rgba32Float;

/// The splat stage: plain, or subsampled, untextured or textured (the key).
#[derive(Resource)]
pub struct SplatPipeline {
    /// 0 the photon map, 1 its tiles' starts, 2 G-buffer position, 3 G-buffer normal,
    /// 4 resolved surfaces, 5 the target, 6 the pixels' kernel statistics.
    pub layout: BindGroupLayoutDescriptor,
    base: ComputePipelineDescriptor,
}

/// Which splat variant a view runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SplatKey {
    /// Photons gather at one pixel of every n×n block (`SUBSAMPLED`).
    pub subsampled: bool,
    /// The scene's material lookups.
    pub lookups: Lookups,
    /// The scene's extra BSDF layers ([`ScatterPaths::LAYERS`]).
    pub layers: ScatterPaths,
    /// The scene has glass or water, under which a disc's photons are left out (`GLASS`).
    pub glass: bool,
    /// Each pixel's kernel shrinks where it blurs (`ADAPTIVE_KERNEL`:
    /// `PhotonMapping::adaptive_kernel`, photons gathered at every pixel).
    pub adaptive_kernel: bool,
}

impl SpecializedComputePipeline for SplatPipeline {
    type Key = SplatKey;

    fn specialize(&self, key: SplatKey) -> ComputePipelineDescriptor {
        let mut shader_defs = material_defs(key.lookups, key.layers);
        if key.subsampled {
            shader_defs.push("SUBSAMPLED".into());
        }
        if key.glass {
            shader_defs.push("GLASS".into());
        }
        if key.adaptive_kernel {
            shader_defs.push("ADAPTIVE_KERNEL".into());
        }
        ComputePipelineDescriptor {
            shader_defs,
            entry_point: Some("gather".into()),
            ..self.base.clone()
        }
    }
}

fn init_splat_pipeline(
    mut commands: Commands,
    shaders: Res<RppmShaders>,
    layouts: Res<ViewLayouts>,
) {
    let unfilterable = TextureSampleType::Float { filterable: false };
    let read = || storage_buffer_read_only_sized(false, None);
    let layout = BindGroupLayoutDescriptor::new(
        "rppm_splat_layout",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                read(),
                read(),
                texture_2d(unfilterable),
                texture_2d(unfilterable),
                read(),
                texture_storage_2d(SPLAT_FORMAT, StorageTextureAccess::WriteOnly),
                storage_buffer_sized(false, None),
            ),
        ),
    );
    let base = tracing_pipeline("rppm_splat", &layouts, &layout, &shaders.splat);
    commands.insert_resource(SplatPipeline { layout, base });
}

/// What each pixel's kernels met since its radius sequence began (`kernel_stats` in
/// `shaders/splat/splat.wgsl`): 16 bytes a pixel where kernels adapt (`kept`: the view's
/// `ResourceKey::adaptive_kernel`), else one texel for the layout's binding. Kept through
/// frames; the importons' (`label`) are cleared where a radius sequence restarts.
pub fn kernel_stats(device: &RenderDevice, size: UVec2, kept: bool, label: &'static str) -> Buffer {
    let size = if kept { size } else { UVec2::ONE };
    crate::view::pixel_buffer(device, size, label, 16, BufferUsages::COPY_DST)
}

/// What a splat target's group binds besides the target.
pub struct SplatInputs<'a> {
    pub store: &'a PhotonStore,
    pub gbuffer: &'a GBuffer,
    /// Each pixel's textures, looked up by local illumination.
    pub surfaces: &'a Buffer,
    /// [`kernel_stats`].
    pub kernel_stats: &'a Buffer,
}

/// One camera's splat target for this frame (from Bevy's `TextureCache`), and the group that
/// binds its photons.
pub struct SplatTarget {
    pub view: TextureView,
    /// Texels of the target (the view's size over the subsampling).
    size: UVec2,
    group: Option<BindGroup>,
}

impl SplatTarget {
    /// This frame's target, from the cache.
    pub fn new(
        cache: &mut TextureCache,
        device: &RenderDevice,
        view_size: UVec2,
        subsampling: u32,
    ) -> Self {
        let size = view_size.map(|v| v.div_ceil(subsampling));
        // Written by the gather, cleared as an attachment when nothing was traced.
        let view = target(
            cache,
            device,
            "rppm_splats",
            size,
            SPLAT_FORMAT,
            TextureUsages::STORAGE_BINDING,
        );
        Self {
            view,
            size,
            group: None,
        }
    }

    /// Binds the photon store (when there is one) with the G-buffer it is splatted onto.
    pub fn bind(
        &mut self,
        device: &RenderDevice,
        cache: &PipelineCache,
        pipeline: &SplatPipeline,
        inputs: SplatInputs,
    ) {
        self.group = Some(device.create_bind_group(
            "rppm_splat_group",
            &cache.get_bind_group_layout(&pipeline.layout),
            &BindGroupEntries::sequential((
                inputs.store.map.photons.as_entire_binding(),
                inputs.store.map.tile_starts.as_entire_binding(),
                &inputs.gbuffer.position,
                &inputs.gbuffer.normal,
                inputs.surfaces.as_entire_binding(),
                &self.view,
                inputs.kernel_stats.as_entire_binding(),
            )),
        ));
    }

    pub fn bytes(&self) -> u64 {
        self.size.x as u64 * self.size.y as u64 * 16
    }

    /// Gathers this iteration's photons at every texel of the target, or clears it when none
    /// were traced (`groups` none).
    pub fn encode(
        &self,
        encoder: &mut CommandEncoder,
        pipeline: Option<&ComputePipeline>,
        groups: Option<&TracingGroups>,
        timer: &mut StageTimer,
    ) {
        if let (Some(pipeline), Some(groups), Some(own)) = (pipeline, groups, &self.group) {
            let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
                label: Some("rppm_splat"),
                timestamp_writes: timer.compute_pass(Stage::Splat),
            });
            groups.bind(&mut pass, pipeline, own);
            pass.dispatch_workgroups(self.size.x.div_ceil(8), self.size.y.div_ceil(8), 1);
            return;
        }
        encoder.begin_render_pass(&RenderPassDescriptor {
            label: Some("rppm_splat_clear"),
            color_attachments: &[Some(RenderPassColorAttachment {
                view: &self.view,
                depth_slice: None,
                resolve_target: None,
                ops: Operations {
                    load: LoadOp::Clear(LinearRgba::NONE.into()),
                    store: StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
    }
}
