//! Direct splatting: each stored photon is a screen quad over the camera G-buffer; fragments
//! add f·Φ/(πr²) to their pixel when the photon lies inside the pixel's gather kernel (a disc
//! of the gather radius on the pixel's surface, flattened along its normal). Subsampled
//! (ISPM), photons land on one pixel of every n×n block as incident light, upsampled in
//! accumulation (`shaders/splat/splat.wgsl`).

use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{storage_buffer_read_only_sized, texture_2d};
use bevy::render::render_resource::*;
use bevy::render::renderer::RenderDevice;
use bevy::render::texture::TextureCache;
use bevy::render::{RenderApp, RenderStartup};
use bevy::shader::Shader;

use crate::gbuffer::{GBuffer, target};
use crate::photons::PhotonStore;
use crate::scene::texture_defs;
use crate::shaders::RppmShaders;
use crate::stats::timing::{Stage, StageTimer};
use crate::view::ViewLayouts;
use crate::view::layouts::params_entry;

pub(crate) struct SplatPlugin;

impl Plugin for SplatPlugin {
    fn build(&self, app: &mut App) {
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app
                .init_resource::<SpecializedRenderPipelines<SplatPipeline>>()
                .add_systems(RenderStartup, init_splat_pipeline);
        }
    }
}

/// The per-iteration splat sums: thousands of photons can overlap a pixel, and half floats
/// stop adding small terms past a few units, so 32-bit floats where they blend.
fn splat_format(device: &RenderDevice) -> TextureFormat {
    if device.features().contains(WgpuFeatures::FLOAT32_BLENDABLE) {
        TextureFormat::Rgba32Float
    } else {
        warn!(
            "bevy_rppm: this GPU cannot blend 32-bit floats; photon splats are summed in half \
             floats, which saturate where very many photons overlap"
        );
        TextureFormat::Rgba16Float
    }
}

/// The splat stage: plain, or subsampled (the key).
#[derive(Resource)]
pub struct SplatPipeline {
    pub format: TextureFormat,
    /// 0 params (dynamic offset), 1 photons, 2 G-buffer position, 3 G-buffer normal.
    pub layout: BindGroupLayoutDescriptor,
    scene: BindGroupLayoutDescriptor,
    shader: Handle<Shader>,
}

/// Which splat variant a view runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SplatKey {
    /// Photons splat onto one pixel of every n×n block (`SUBSAMPLED`).
    pub subsampled: bool,
    /// The scene's texture lookups (`TEXTURED`).
    pub textured: bool,
}

impl SpecializedRenderPipeline for SplatPipeline {
    type Key = SplatKey;

    fn specialize(&self, key: SplatKey) -> RenderPipelineDescriptor {
        let mut shader_defs = texture_defs(key.textured);
        if key.subsampled {
            shader_defs.push("SUBSAMPLED".into());
        }
        let additive = BlendComponent {
            src_factor: BlendFactor::One,
            dst_factor: BlendFactor::One,
            operation: BlendOperation::Add,
        };
        RenderPipelineDescriptor {
            label: Some("rppm_splat".into()),
            layout: vec![self.scene.clone(), self.layout.clone()],
            vertex: VertexState {
                shader: self.shader.clone(),
                shader_defs: shader_defs.clone(),
                ..default()
            },
            fragment: Some(FragmentState {
                shader: self.shader.clone(),
                shader_defs,
                targets: vec![Some(ColorTargetState {
                    format: self.format,
                    blend: Some(BlendState {
                        color: additive,
                        alpha: additive,
                    }),
                    write_mask: ColorWrites::ALL,
                })],
                ..default()
            }),
            ..default()
        }
    }
}

fn init_splat_pipeline(
    mut commands: Commands,
    device: Res<RenderDevice>,
    shaders: Res<RppmShaders>,
    layouts: Res<ViewLayouts>,
) {
    let unfilterable = TextureSampleType::Float { filterable: false };
    let layout = BindGroupLayoutDescriptor::new(
        "rppm_splat_layout",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::VERTEX_FRAGMENT,
            (
                params_entry(),
                storage_buffer_read_only_sized(false, None),
                texture_2d(unfilterable),
                texture_2d(unfilterable),
                storage_buffer_read_only_sized(false, None),
            ),
        ),
    );
    commands.insert_resource(SplatPipeline {
        format: splat_format(&device),
        layout,
        scene: layouts.scene.clone(),
        shader: shaders.splat.clone(),
    });
}

/// One camera's splat target for this frame (from Bevy's `TextureCache`), and the group that
/// binds its photons.
pub struct SplatTarget {
    pub view: TextureView,
    /// Texels of the target (the view's size over the subsampling).
    size: UVec2,
    subsampling: u32,
    group: Option<BindGroup>,
}

impl SplatTarget {
    /// This frame's target, from the cache.
    pub fn new(
        cache: &mut TextureCache,
        device: &RenderDevice,
        pipeline: &SplatPipeline,
        view_size: UVec2,
        subsampling: u32,
    ) -> Self {
        let size = view_size.map(|v| v.div_ceil(subsampling));
        let view = target(cache, device, "rppm_splats", size, pipeline.format);
        Self {
            view,
            size,
            subsampling,
            group: None,
        }
    }

    /// Binds the photon store (when there is one) with the G-buffer it is splatted onto.
    #[expect(clippy::too_many_arguments, reason = "the inputs of the splat's group")]
    pub fn bind(
        &mut self,
        device: &RenderDevice,
        cache: &PipelineCache,
        pipeline: &SplatPipeline,
        params: BufferBinding,
        store: &PhotonStore,
        gbuffer: &GBuffer,
        surfaces: &Buffer,
    ) {
        self.group = Some(device.create_bind_group(
            "rppm_splat_group",
            &cache.get_bind_group_layout(&pipeline.layout),
            &BindGroupEntries::sequential((
                params,
                store.photons.as_entire_binding(),
                &gbuffer.position,
                &gbuffer.normal,
                surfaces.as_entire_binding(),
            )),
        ));
    }

    pub fn bytes(&self) -> u64 {
        self.size.x as u64 * self.size.y as u64 * 16
    }

    /// Clears the target and, when photons were traced, splats them onto it.
    #[expect(
        clippy::too_many_arguments,
        reason = "the groups and targets of a splat pass"
    )]
    pub fn encode(
        &self,
        encoder: &mut CommandEncoder,
        pipeline: Option<&RenderPipeline>,
        store: Option<&PhotonStore>,
        scene_group: &BindGroup,
        offset: u32,
        view_size: UVec2,
        timer: &mut StageTimer,
    ) {
        let size = view_size.as_vec2() / self.subsampling as f32;
        let mut pass = encoder.begin_render_pass(&RenderPassDescriptor {
            label: Some("rppm_splat"),
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
            timestamp_writes: timer.render_pass(Stage::Splat),
            occlusion_query_set: None,
            multiview_mask: None,
        });
        if let (Some(pipeline), Some(store), Some(group)) = (pipeline, store, &self.group) {
            // The view's pixels over the subsampling (fractional where it does not divide), so
            // that clip space maps onto whole blocks of pixels.
            pass.set_viewport(0.0, 0.0, size.x, size.y, 0.0, 1.0);
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, scene_group, &[]);
            pass.set_bind_group(1, group, &[offset]);
            pass.draw_indirect(&store.count, 0);
        }
    }
}
