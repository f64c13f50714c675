//! Shaders (embedded at compile time) and the pipelines of every stage.

use std::num::NonZeroU64;

use bevy::platform::collections::HashMap;
use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{
    storage_buffer_read_only_sized, storage_buffer_sized, texture_2d, texture_2d_array,
    uniform_buffer_sized,
};
use bevy::render::render_resource::*;
use bevy::shader::Shader;

use crate::shadows::SHADOW_FORMAT;
use crate::variants::Variants;
use crate::view::IterationParams;

pub const GBUFFER_FORMAT: TextureFormat = TextureFormat::Rgba32Float;
pub const DEPTH_FORMAT: TextureFormat = TextureFormat::Depth32Float;

/// Handles of our WGSL, added to `Assets<Shader>` from strings compiled into the crate.
#[derive(Resource, Clone)]
pub struct RppmShaders {
    /// Import-only libraries, held so they stay loaded.
    _libraries: Vec<Handle<Shader>>,
    pub shadow: Handle<Shader>,
    pub gbuffer: Handle<Shader>,
    pub local_illumination: Handle<Shader>,
    pub output: Handle<Shader>,
    pub dirt_build: Handle<Shader>,
    pub dirt_bench: Handle<Shader>,
    pub debug_view: Handle<Shader>,
    pub photon: Handle<Shader>,
    pub splat: Handle<Shader>,
    pub accumulate: Handle<Shader>,
    pub indirect_splat: Handle<Shader>,
}

macro_rules! wgsl {
    ($shaders:expr, $name:literal) => {
        $shaders.add(Shader::from_wgsl(
            include_str!(concat!("../shaders/", $name)),
            concat!("bevy_rppm/shaders/", $name),
        ))
    };
}

impl RppmShaders {
    pub fn load(shaders: &mut Assets<Shader>) -> Self {
        Self {
            _libraries: vec![
                wgsl!(shaders, "common.wgsl"),
                wgsl!(shaders, "scene.wgsl"),
                wgsl!(shaders, "bsdf.wgsl"),
                wgsl!(shaders, "dirt.wgsl"),
                wgsl!(shaders, "lighting.wgsl"),
            ],
            dirt_build: wgsl!(shaders, "dirt_build.wgsl"),
            dirt_bench: wgsl!(shaders, "dirt_bench.wgsl"),
            debug_view: wgsl!(shaders, "debug_view.wgsl"),
            photon: wgsl!(shaders, "photon.wgsl"),
            splat: wgsl!(shaders, "splat.wgsl"),
            accumulate: wgsl!(shaders, "accumulate.wgsl"),
            indirect_splat: wgsl!(shaders, "indirect_splat.wgsl"),
            shadow: wgsl!(shaders, "shadow.wgsl"),
            gbuffer: wgsl!(shaders, "gbuffer.wgsl"),
            local_illumination: wgsl!(shaders, "local_illumination.wgsl"),
            output: wgsl!(shaders, "output.wgsl"),
        }
    }
}

/// Bind group layouts and queued pipelines.
#[derive(Resource)]
pub struct RppmPipelines {
    /// 0 triangles, 1 shadow views, 2 materials, 3 lights, 4 emitters, 5 light CDF.
    pub scene_layout: BindGroupLayoutDescriptor,
    /// 0 per-iteration params (dynamic offset).
    pub params_layout: BindGroupLayoutDescriptor,
    /// 0 G-buffer position, 1 G-buffer normal, 2 shadow maps, 3 this iteration's samples,
    /// 4 importons, 5 importon lists' heads, 6 importon stats.
    pub local_layout: BindGroupLayoutDescriptor,
    /// 0 params (dynamic offset), 1 radiance.
    pub output_layout: BindGroupLayoutDescriptor,
    pub shadow: CachedRenderPipelineId,
    pub gbuffer: CachedRenderPipelineId,
    pub local_illumination: CachedComputePipelineId,
    /// Local illumination that also follows camera paths through specular surfaces, by the
    /// scene's specular paths (MIRRORS, REFRACTION); queued on first use.
    pub local_importons: Variants<ComputePipelineDescriptor>,
    output_shader: Handle<Shader>,
    output: HashMap<(TextureFormat, bool), CachedRenderPipelineId>,
}

fn params_size() -> Option<NonZeroU64> {
    NonZeroU64::new(std::mem::size_of::<IterationParams>() as u64)
}

impl RppmPipelines {
    pub fn new(cache: &PipelineCache, shaders: &RppmShaders) -> Self {
        let all = ShaderStages::VERTEX | ShaderStages::FRAGMENT | ShaderStages::COMPUTE;
        let scene_layout = BindGroupLayoutDescriptor::new(
            "rppm_scene_layout",
            &BindGroupLayoutEntries::sequential(
                all,
                (
                    storage_buffer_read_only_sized(false, None),
                    storage_buffer_read_only_sized(false, None),
                    storage_buffer_read_only_sized(false, None),
                    storage_buffer_read_only_sized(false, None),
                    storage_buffer_read_only_sized(false, None),
                    storage_buffer_read_only_sized(false, None),
                ),
            ),
        );
        let params_layout = BindGroupLayoutDescriptor::new(
            "rppm_params_layout",
            &BindGroupLayoutEntries::single(all, uniform_buffer_sized(true, params_size())),
        );
        let unfilterable = TextureSampleType::Float { filterable: false };
        let local_layout = BindGroupLayoutDescriptor::new(
            "rppm_local_layout",
            &BindGroupLayoutEntries::sequential(
                ShaderStages::COMPUTE,
                (
                    texture_2d(unfilterable),
                    texture_2d(unfilterable),
                    texture_2d_array(TextureSampleType::Depth),
                    storage_buffer_sized(false, None),
                    storage_buffer_sized(false, None),
                    storage_buffer_sized(false, None),
                    storage_buffer_sized(false, None),
                ),
            ),
        );
        let output_layout = BindGroupLayoutDescriptor::new(
            "rppm_output_layout",
            &BindGroupLayoutEntries::sequential(
                ShaderStages::FRAGMENT,
                (
                    uniform_buffer_sized(true, params_size()),
                    storage_buffer_read_only_sized(false, None),
                ),
            ),
        );
        let shadow = cache.queue_render_pipeline(RenderPipelineDescriptor {
            label: Some("rppm_shadow_pipeline".into()),
            layout: vec![scene_layout.clone()],
            vertex: VertexState {
                shader: shaders.shadow.clone(),
                ..default()
            },
            depth_stencil: Some(depth_state(SHADOW_FORMAT, CompareFunction::Less)),
            ..default()
        });
        let gbuffer_target = Some(ColorTargetState {
            format: GBUFFER_FORMAT,
            blend: None,
            write_mask: ColorWrites::ALL,
        });
        let gbuffer = cache.queue_render_pipeline(RenderPipelineDescriptor {
            label: Some("rppm_gbuffer_pipeline".into()),
            layout: vec![scene_layout.clone(), params_layout.clone()],
            vertex: VertexState {
                shader: shaders.gbuffer.clone(),
                ..default()
            },
            fragment: Some(FragmentState {
                shader: shaders.gbuffer.clone(),
                targets: vec![gbuffer_target.clone(), gbuffer_target],
                ..default()
            }),
            // Reverse Z, as Bevy's camera projections.
            depth_stencil: Some(depth_state(DEPTH_FORMAT, CompareFunction::Greater)),
            ..default()
        });
        let local = ComputePipelineDescriptor {
            label: Some("rppm_local_illumination_pipeline".into()),
            layout: vec![
                scene_layout.clone(),
                params_layout.clone(),
                local_layout.clone(),
            ],
            shader: shaders.local_illumination.clone(),
            ..default()
        };
        let local_illumination = cache.queue_compute_pipeline(local.clone());
        let mut importons = local;
        importons.layout.push(crate::cubemap::trace_layout());
        importons.shader_defs.push("IMPORTONS".into());
        let local_importons = Variants::new(importons);
        Self {
            scene_layout,
            params_layout,
            local_layout,
            output_layout,
            shadow,
            gbuffer,
            local_illumination,
            local_importons,
            output_shader: shaders.output.clone(),
            output: HashMap::default(),
        }
    }

    /// The output pipeline for a view's texture format: replacing the view (mode Full) or
    /// adding to it (mode Indirect), queued the first time it is asked for.
    pub fn output_pipeline(
        &mut self,
        cache: &PipelineCache,
        format: TextureFormat,
        additive: bool,
    ) -> CachedRenderPipelineId {
        let shader = self.output_shader.clone();
        let layout = self.output_layout.clone();
        let add = BlendComponent {
            src_factor: BlendFactor::One,
            dst_factor: BlendFactor::One,
            operation: BlendOperation::Add,
        };
        let blend = additive.then_some(BlendState {
            color: add,
            alpha: BlendComponent::REPLACE,
        });
        *self.output.entry((format, additive)).or_insert_with(|| {
            cache.queue_render_pipeline(RenderPipelineDescriptor {
                label: Some("rppm_output_pipeline".into()),
                layout: vec![layout],
                vertex: VertexState {
                    shader: shader.clone(),
                    ..default()
                },
                fragment: Some(FragmentState {
                    shader,
                    targets: vec![Some(ColorTargetState {
                        format,
                        blend,
                        write_mask: ColorWrites::ALL,
                    })],
                    ..default()
                }),
                ..default()
            })
        })
    }
}

fn depth_state(format: TextureFormat, compare: CompareFunction) -> DepthStencilState {
    DepthStencilState {
        format,
        depth_write_enabled: Some(true),
        depth_compare: Some(compare),
        stencil: default(),
        bias: default(),
    }
}

pub(crate) fn init_pipelines(
    mut commands: Commands,
    cache: Res<PipelineCache>,
    shaders: Res<RppmShaders>,
) {
    commands.insert_resource(RppmPipelines::new(&cache, &shaders));
}
