//! Photon tracing through the deep cubemap, direct splatting of the stored photons onto the
//! camera G-buffer, and the per-iteration accumulation of the estimate.

use std::num::NonZeroU64;

use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{
    storage_buffer_read_only_sized, storage_buffer_sized, texture_2d, uniform_buffer_sized,
};
use bevy::render::render_resource::*;
use bevy::render::renderer::RenderDevice;
use bevy::shader::Shader;

use crate::cubemap::CubemapPipelines;
use crate::pipelines::{RppmPipelines, RppmShaders};
use crate::timing::{Stage, StageTimer};
use crate::variants::Variants;
use crate::view::IterationParams;

/// Byte offset of the indirect splat's dispatch arguments in the importon stats buffer.
const IMPORTON_DISPATCH: u64 = 16;

/// Bytes of one stored photon (`Photon` in common.wgsl).
pub const PHOTON_BYTES: u64 = 64;
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

#[derive(Resource)]
pub struct PhotonPipelines {
    splat_format: TextureFormat,
    store_layout: BindGroupLayoutDescriptor,
    splat_layout: BindGroupLayoutDescriptor,
    accumulate_layout: BindGroupLayoutDescriptor,
    indirect_layout: BindGroupLayoutDescriptor,
    /// By the scene's scattering paths (`SceneData::path_features`).
    trace: Variants<ComputePipelineDescriptor>,
    /// Plain or SUBSAMPLED.
    splat: Variants<RenderPipelineDescriptor>,
    /// By IMPORTONS and SUBSAMPLED.
    accumulate: Variants<ComputePipelineDescriptor>,
    indirect_splat: Variants<ComputePipelineDescriptor>,
}

/// The photon stages' pipelines one view runs with, by its scene and settings.
#[derive(Clone, Copy)]
pub struct PhotonStageIds {
    pub trace: Option<CachedComputePipelineId>,
    pub splat: Option<CachedRenderPipelineId>,
    pub accumulate: CachedComputePipelineId,
    pub indirect_splat: Option<CachedComputePipelineId>,
}

fn params_entry() -> BindGroupLayoutEntryBuilder {
    uniform_buffer_sized(true, NonZeroU64::new(size_of::<IterationParams>() as u64))
}

pub(crate) fn init_photon_pipelines(
    mut commands: Commands,
    device: Res<RenderDevice>,
    shaders: Res<RppmShaders>,
    rppm: Res<RppmPipelines>,
    cubemap: Res<CubemapPipelines>,
) {
    let splat_format = splat_format(&device);
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
    let unfilterable = TextureSampleType::Float { filterable: false };
    let splat_layout = BindGroupLayoutDescriptor::new(
        "rppm_splat_layout",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::VERTEX_FRAGMENT,
            (
                params_entry(),
                storage_buffer_read_only_sized(false, None),
                texture_2d(unfilterable),
                texture_2d(unfilterable),
            ),
        ),
    );
    let accumulate_layout = BindGroupLayoutDescriptor::new(
        "rppm_accumulate_layout",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                params_entry(),
                storage_buffer_read_only_sized(false, None),
                texture_2d(unfilterable),
                storage_buffer_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                texture_2d(unfilterable),
                texture_2d(unfilterable),
            ),
        ),
    );
    let read = || storage_buffer_read_only_sized(false, None);
    let indirect_layout = BindGroupLayoutDescriptor::new(
        "rppm_indirect_splat_layout",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                read(),
                read(),
                read(),
                read(),
                read(),
                storage_buffer_sized(false, None),
            ),
        ),
    );
    // Tracing stages: scene, iteration constants, their own group, the deep cubemap.
    let tracing =
        |label: &'static str, own: &BindGroupLayoutDescriptor, shader: &Handle<Shader>| {
            Variants::new(ComputePipelineDescriptor {
                label: Some(label.into()),
                layout: vec![
                    rppm.scene_layout.clone(),
                    rppm.params_layout.clone(),
                    own.clone(),
                    cubemap.trace_layout.clone(),
                ],
                shader: shader.clone(),
                ..default()
            })
        };
    let trace = tracing("rppm_photon_trace", &store_layout, &shaders.photon);
    let additive = BlendComponent {
        src_factor: BlendFactor::One,
        dst_factor: BlendFactor::One,
        operation: BlendOperation::Add,
    };
    let splat = Variants::new(RenderPipelineDescriptor {
        label: Some("rppm_splat".into()),
        layout: vec![rppm.scene_layout.clone(), splat_layout.clone()],
        vertex: VertexState {
            shader: shaders.splat.clone(),
            ..default()
        },
        fragment: Some(FragmentState {
            shader: shaders.splat.clone(),
            targets: vec![Some(ColorTargetState {
                format: splat_format,
                blend: Some(BlendState {
                    color: additive,
                    alpha: additive,
                }),
                write_mask: ColorWrites::ALL,
            })],
            ..default()
        }),
        ..default()
    });
    let accumulate = Variants::new(ComputePipelineDescriptor {
        label: Some("rppm_accumulate".into()),
        layout: vec![rppm.scene_layout.clone(), accumulate_layout.clone()],
        shader: shaders.accumulate.clone(),
        ..default()
    });
    let indirect_splat = tracing(
        "rppm_indirect_splat",
        &indirect_layout,
        &shaders.indirect_splat,
    );
    commands.insert_resource(PhotonPipelines {
        splat_format,
        store_layout,
        splat_layout,
        accumulate_layout,
        indirect_layout,
        trace,
        splat,
        accumulate,
        indirect_splat,
    });
}

/// The per-view targets of splatting and accumulation, and the photon store when the scene
/// has lights to emit from.
pub struct PhotonTargets {
    pub samples: Buffer,
    /// One importon per pixel, the heads of the cubemap tiles' importon lists, and
    /// (largest radius, count); 16-byte stand-ins when there are no importons.
    pub importons: Buffer,
    pub importon_heads: Buffer,
    pub importon_stats: Buffer,
    /// Per pixel, the photons the pixel's importon gathered.
    importon_radiance: Buffer,
    indirect_group: Option<BindGroup>,
    splats: TextureView,
    /// Texels of the splat target (the view's size over the subsampling).
    splat_size: UVec2,
    subsampling: u32,
    accumulate_group: BindGroup,
    store: Option<PhotonStore>,
}

struct PhotonStore {
    photons: Buffer,
    /// Draw-indirect arguments whose instance count is the number of photons stored.
    count: Buffer,
    store_group: BindGroup,
    splat_group: BindGroup,
}

/// The bind groups every tracing stage shares: scene (0), this iteration's constants (1, at
/// `offset`) and the deep cubemap (3); group 2 is the stage's own.
pub struct TracingGroups<'a> {
    pub scene: &'a BindGroup,
    pub params: &'a BindGroup,
    pub offset: u32,
    pub cubemap: &'a BindGroup,
}

impl TracingGroups<'_> {
    fn bind(&self, pass: &mut ComputePass, pipeline: &ComputePipeline, own: &BindGroup) {
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, self.scene, &[]);
        pass.set_bind_group(1, self.params, &[self.offset]);
        pass.set_bind_group(2, own, &[]);
        pass.set_bind_group(3, self.cubemap, &[]);
    }
}

/// What `PhotonTargets::new` binds.
pub struct TargetInputs<'a> {
    pub size: UVec2,
    pub params: BufferBinding<'a>,
    pub radiance: &'a Buffer,
    pub gbuffer_position: &'a TextureView,
    pub gbuffer_normal: &'a TextureView,
    /// Room for stored photons; 0 when the scene emits none.
    pub photon_capacity: u32,
    /// Deep-cubemap tiles importons register in; 0 when no camera path goes past the
    /// G-buffer (no specular surfaces, or max eye depth 1).
    pub importon_tiles: u32,
    /// Photons splat on every n-th pixel in x and y (1, 2 or 4).
    pub subsampling: u32,
}

impl PhotonTargets {
    pub fn new(
        device: &RenderDevice,
        cache: &PipelineCache,
        pipelines: &PhotonPipelines,
        inputs: TargetInputs,
    ) -> Self {
        let pixels = inputs.size.x as u64 * inputs.size.y as u64;
        let splat_size = inputs.size.map(|v| v.div_ceil(inputs.subsampling));
        let samples = device.create_buffer(&BufferDescriptor {
            label: Some("rppm_samples"),
            size: pixels * 16,
            usage: BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let splats = device
            .create_texture(&TextureDescriptor {
                label: Some("rppm_splats"),
                size: Extent3d {
                    width: splat_size.x,
                    height: splat_size.y,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: TextureDimension::D2,
                format: pipelines.splat_format,
                usage: TextureUsages::RENDER_ATTACHMENT | TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            })
            .create_view(&TextureViewDescriptor::default());
        let storage = |label: &'static str, size: u64| {
            device.create_buffer(&BufferDescriptor {
                label: Some(label),
                size: size.max(16),
                usage: BufferUsages::STORAGE | BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let with_importons = inputs.importon_tiles > 0;
        let per_pixel = |bytes: u64| if with_importons { pixels * bytes } else { 0 };
        let importons = storage("rppm_importons", per_pixel(64));
        let importon_heads = storage("rppm_importon_heads", inputs.importon_tiles as u64 * 4);
        // [largest radius, importons made, -, -, dispatch x, y, z, -]: the local stage sets the
        // indirect splat's workgroup count only when it makes an importon.
        let importon_stats = device.create_buffer_with_data(&BufferInitDescriptor {
            label: Some("rppm_importon_stats"),
            contents: bytemuck::cast_slice(&[0u32, 0, 0, 0, 0, 1, 1, 0]),
            usage: BufferUsages::STORAGE
                | BufferUsages::COPY_DST
                | BufferUsages::COPY_SRC
                | BufferUsages::INDIRECT,
        });
        let importon_radiance = storage("rppm_importon_radiance", per_pixel(16));
        let accumulate_group = device.create_bind_group(
            "rppm_accumulate_group",
            &cache.get_bind_group_layout(&pipelines.accumulate_layout),
            &BindGroupEntries::sequential((
                inputs.params.clone(),
                samples.as_entire_binding(),
                &splats,
                inputs.radiance.as_entire_binding(),
                importon_radiance.as_entire_binding(),
                inputs.gbuffer_position,
                inputs.gbuffer_normal,
            )),
        );
        let store = (inputs.photon_capacity > 0).then(|| {
            let photons = device.create_buffer(&BufferDescriptor {
                label: Some("rppm_photons"),
                size: inputs.photon_capacity as u64 * PHOTON_BYTES,
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
            let store_group = device.create_bind_group(
                "rppm_photon_store_group",
                &cache.get_bind_group_layout(&pipelines.store_layout),
                &BindGroupEntries::sequential((
                    photons.as_entire_binding(),
                    count.as_entire_binding(),
                )),
            );
            let splat_group = device.create_bind_group(
                "rppm_splat_group",
                &cache.get_bind_group_layout(&pipelines.splat_layout),
                &BindGroupEntries::sequential((
                    inputs.params.clone(),
                    photons.as_entire_binding(),
                    inputs.gbuffer_position,
                    inputs.gbuffer_normal,
                )),
            );
            PhotonStore {
                photons,
                count,
                store_group,
                splat_group,
            }
        });
        let indirect_group = store.as_ref().filter(|_| with_importons).map(|store| {
            device.create_bind_group(
                "rppm_indirect_splat_group",
                &cache.get_bind_group_layout(&pipelines.indirect_layout),
                &BindGroupEntries::sequential((
                    store.photons.as_entire_binding(),
                    store.count.as_entire_binding(),
                    importons.as_entire_binding(),
                    importon_heads.as_entire_binding(),
                    importon_stats.as_entire_binding(),
                    importon_radiance.as_entire_binding(),
                )),
            )
        });
        Self {
            samples,
            importons,
            importon_heads,
            importon_stats,
            importon_radiance,
            indirect_group,
            splats,
            splat_size,
            subsampling: inputs.subsampling,
            accumulate_group,
            store,
        }
    }

    /// The buffer whose second u32 counts the photons stored in the last iteration.
    pub fn photon_count(&self) -> Option<&Buffer> {
        self.store.as_ref().map(|s| &s.count)
    }

    pub fn memory(&self) -> Vec<(&'static str, u64)> {
        let splat_texels = self.splat_size.x as u64 * self.splat_size.y as u64;
        let mut memory = vec![
            ("samples", self.samples.size()),
            ("splats", splat_texels * 16),
            ("importons", self.importons.size()),
            ("importon_heads", self.importon_heads.size()),
            ("importon_radiance", self.importon_radiance.size()),
        ];
        if let Some(store) = &self.store {
            memory.push(("photons", store.photons.size()));
        }
        memory
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
        let Some(store) = &self.store else { return };
        encoder.clear_buffer(&store.count, 4, Some(4));
        let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
            label: Some("rppm_photon_trace"),
            timestamp_writes: timer.compute_pass(Stage::PhotonTrace),
        });
        groups.bind(&mut pass, pipeline, &store.store_group);
        pass.dispatch_workgroups(photons.div_ceil(64), 1, 1);
    }

    /// Clears the splat target and, when photons were traced, splats them onto it.
    pub fn encode_splat(
        &self,
        encoder: &mut CommandEncoder,
        pipeline: Option<&RenderPipeline>,
        scene_group: &BindGroup,
        offset: u32,
        view_size: UVec2,
        timer: &mut StageTimer,
    ) {
        let size = view_size.as_vec2() / self.subsampling as f32;
        let mut pass = encoder.begin_render_pass(&RenderPassDescriptor {
            label: Some("rppm_splat"),
            color_attachments: &[Some(RenderPassColorAttachment {
                view: &self.splats,
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
        if let (Some(pipeline), Some(store)) = (pipeline, &self.store) {
            // The view's pixels over the subsampling (fractional where it does not divide), so
            // that clip space maps onto whole blocks of pixels.
            pass.set_viewport(0.0, 0.0, size.x, size.y, 0.0, 1.0);
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, scene_group, &[]);
            pass.set_bind_group(1, &store.splat_group, &[offset]);
            pass.draw_indirect(&store.count, 0);
        }
    }

    /// Empties the importon lists and gathered light before an iteration's camera paths.
    pub fn encode_importon_clear(&self, encoder: &mut CommandEncoder) {
        for buffer in [&self.importon_heads, &self.importon_radiance] {
            encoder.clear_buffer(buffer, 0, None);
        }
        // The stats and the dispatch's x; its y and z stay 1.
        encoder.clear_buffer(&self.importon_stats, 0, Some(IMPORTON_DISPATCH + 4));
    }

    /// Indirect splatting: stored photons against the importons in the cubemap's tiles.
    /// Dispatched indirectly: no workgroup runs when no importon was made this iteration.
    pub fn encode_indirect_splat(
        &self,
        encoder: &mut CommandEncoder,
        pipeline: &ComputePipeline,
        groups: &TracingGroups,
        timer: &mut StageTimer,
    ) {
        let Some(group) = &self.indirect_group else {
            return;
        };
        let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
            label: Some("rppm_indirect_splat"),
            timestamp_writes: timer.compute_pass(Stage::IndirectSplat),
        });
        groups.bind(&mut pass, pipeline, group);
        pass.dispatch_workgroups_indirect(&self.importon_stats, IMPORTON_DISPATCH);
    }

    /// Adds the splats to the local sample and folds it into the running estimate.
    pub fn encode_accumulate(
        &self,
        encoder: &mut CommandEncoder,
        pipeline: &ComputePipeline,
        scene_group: &BindGroup,
        size: UVec2,
        offset: u32,
        timer: &mut StageTimer,
    ) {
        let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
            label: Some("rppm_accumulate"),
            timestamp_writes: timer.compute_pass(Stage::Accumulate),
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, scene_group, &[]);
        pass.set_bind_group(1, &self.accumulate_group, &[offset]);
        pass.dispatch_workgroups(size.x.div_ceil(8), size.y.div_ceil(8), 1);
    }
}

impl PhotonPipelines {
    /// The pipelines for a scene with these scattering paths (no photon stages when it emits
    /// no photons), with or without importons and subsampled splats; queued on first use.
    pub fn stage_ids(
        &mut self,
        cache: &PipelineCache,
        paths: Option<&[&'static str]>,
        importons: bool,
        subsampled: bool,
    ) -> PhotonStageIds {
        let subsampled = if subsampled { &["SUBSAMPLED"][..] } else { &[] };
        let mut accumulate_defs = subsampled.to_vec();
        if importons {
            accumulate_defs.push("IMPORTONS");
        }
        PhotonStageIds {
            trace: paths.map(|paths| self.trace.get(cache, paths)),
            splat: paths.map(|_| self.splat.get(cache, subsampled)),
            accumulate: self.accumulate.get(cache, &accumulate_defs),
            indirect_splat: paths
                .filter(|_| importons)
                .map(|_| self.indirect_splat.get(cache, &[])),
        }
    }
}
