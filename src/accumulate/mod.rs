//! Accumulation: this iteration's sample (local light, direct and indirect splats) folded into
//! the running mean of every iteration since the last reset (`shaders/accumulate/`). With
//! subsampled splats, the incident light is upsampled by a joint-bilateral filter before each
//! pixel's own BSDF. Under `RppmHistory::Reuse` it also keeps each pixel's history through
//! motion (`history.rs`). Where camera paths go on, outlying samples are spread first
//! (`outliers.rs`).

mod clock;
mod history;
mod outliers;
mod resolve;

pub use clock::{Changes, HistoryClock, HistoryFlags};
pub use history::History;
pub(crate) use history::history_fits;
pub use outliers::{OutlierPipelines, Outliers};
pub use resolve::{ResolveKey, ResolvePipeline, Resolved, resolve_share};

use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{
    storage_buffer_read_only_sized, storage_buffer_sized, texture_2d,
};
use bevy::render::render_resource::*;
use bevy::render::renderer::RenderDevice;
use bevy::render::{RenderApp, RenderStartup};
use bevy::shader::Shader;

use crate::gbuffer::GBuffer;
use crate::importons::EyePaths;
use crate::scene::{Lookups, ScatterPaths, material_defs};
use crate::shaders::RppmShaders;
use crate::splat::SplatTarget;
use crate::stats::timing::{Stage, StageTimer};
use crate::view::layouts::params_entry;
use crate::view::{ViewLayouts, pixel_buffer};

pub(crate) struct AccumulatePlugin;

impl Plugin for AccumulatePlugin {
    fn build(&self, app: &mut App) {
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app
                .init_resource::<SpecializedComputePipelines<AccumulatePipeline>>()
                .init_resource::<SpecializedComputePipelines<ResolvePipeline>>()
                .add_systems(RenderStartup, init_accumulate_pipeline);
        }
    }
}

/// The accumulation stage, specialized by [`AccumulateKey`].
#[derive(Resource)]
pub struct AccumulatePipeline {
    /// 0 params (dynamic offset), 1 samples, 2 splats, 3 the running estimate (rgb, w the
    /// pixel's iteration count), 4 importon radiance, 5 G-buffer position, 6 G-buffer normal.
    pub layout: BindGroupLayoutDescriptor,
    /// `layout` and the history (`HISTORY`): 7 the pixels' history, 8 and 9 last frame's
    /// estimate and history, 10 the importons.
    pub history_layout: BindGroupLayoutDescriptor,
    scene: BindGroupLayoutDescriptor,
    shader: Handle<Shader>,
    /// The outlier passes run before it where camera paths go on.
    pub outliers: OutlierPipelines,
    /// What a `Reuse` view shows after a camera move.
    pub resolve: ResolvePipeline,
}

/// What a view's iteration adds up.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct AccumulateKey {
    /// Splats were gathered on one pixel of every n×n block (`SUBSAMPLED`).
    pub subsampled: bool,
    /// Importons gathered photons too (`IMPORTONS`).
    pub importons: bool,
    /// The scene's material lookups.
    pub lookups: Lookups,
    /// The scene's extra BSDF layers ([`ScatterPaths::LAYERS`]).
    pub layers: ScatterPaths,
    /// History kept through motion (`HISTORY`): `RppmHistory::Reuse`.
    pub history: bool,
    /// The scene has emissive surfaces (`EMITTERS`), whose rims a change elsewhere leaves
    /// alone (`HISTORY`).
    pub emitters: bool,
    /// Direct light is exact at each sample's point (`EXACT_DIRECT`: up to 8 point, spot and
    /// directional lights alone, no sphere light, emitter or sky to sample), so that a camera
    /// move keeps little of its history (`HISTORY`).
    pub exact_direct: bool,
    /// Textures or vertex colours vary albedo (`DEMODULATED`, with `HISTORY`): the history
    /// keeps its mean, and a camera move keeps the light on it and shows the albedo of each
    /// pixel's footprint now.
    pub demodulated: bool,
}

impl SpecializedComputePipeline for AccumulatePipeline {
    type Key = AccumulateKey;

    fn specialize(&self, key: AccumulateKey) -> ComputePipelineDescriptor {
        let mut shader_defs = material_defs(key.lookups, key.layers);
        if key.subsampled {
            shader_defs.push("SUBSAMPLED".into());
        }
        if key.importons {
            shader_defs.push("IMPORTONS".into());
        }
        let layout = if key.history {
            shader_defs.push("HISTORY".into());
            if key.emitters {
                shader_defs.push("EMITTERS".into());
            }
            if key.exact_direct {
                shader_defs.push("EXACT_DIRECT".into());
            }
            if key.demodulated {
                shader_defs.push("DEMODULATED".into());
            }
            &self.history_layout
        } else {
            &self.layout
        };
        ComputePipelineDescriptor {
            label: Some("rppm_accumulate".into()),
            layout: vec![self.scene.clone(), layout.clone()],
            shader: self.shader.clone(),
            shader_defs,
            ..default()
        }
    }
}

fn init_accumulate_pipeline(
    mut commands: Commands,
    shaders: Res<RppmShaders>,
    layouts: Res<ViewLayouts>,
    cache: Res<PipelineCache>,
) {
    let unfilterable = TextureSampleType::Float { filterable: false };
    let entries = BindGroupLayoutEntries::sequential(
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
    );
    let history = BindGroupLayoutEntries::with_indices(
        ShaderStages::COMPUTE,
        (
            (7, storage_buffer_sized(false, None)),
            (8, storage_buffer_read_only_sized(false, None)),
            (9, storage_buffer_read_only_sized(false, None)),
            (10, storage_buffer_read_only_sized(false, None)),
        ),
    );
    let with_history: Vec<_> = entries.iter().chain(history.iter()).cloned().collect();
    let layout = BindGroupLayoutDescriptor::new("rppm_accumulate_layout", &entries);
    let history_layout =
        BindGroupLayoutDescriptor::new("rppm_accumulate_history_layout", &with_history);
    commands.insert_resource(AccumulatePipeline {
        layout,
        history_layout,
        scene: layouts.scene.clone(),
        shader: shaders.accumulate.clone(),
        outliers: OutlierPipelines::new(&cache, &shaders, &layouts.scene),
        resolve: ResolvePipeline::new(&layouts, shaders.resolve.clone()),
    });
}

/// One camera's running estimate (linear radiance and iteration count, RGBA f32 per pixel),
/// its history through motion (`Reuse` only), and the group that folds an iteration into it
/// (made again each frame: its targets come from the texture cache).
pub struct Estimate {
    pub radiance: Buffer,
    pub history: Option<History>,
    /// Held where camera paths go on past the G-buffer.
    pub outliers: Option<Outliers>,
    /// What the view shows and reads back, with `history`.
    pub resolved: Option<Resolved>,
    group: Option<BindGroup>,
}

/// What an estimate's group binds.
pub struct EstimateInputs<'a> {
    pub params: BufferBinding<'a>,
    pub eye_paths: &'a EyePaths,
    pub splats: &'a SplatTarget,
    pub gbuffer: &'a GBuffer,
}

impl Estimate {
    pub fn new(
        device: &RenderDevice,
        size: UVec2,
        history: bool,
        importons: bool,
        demodulated: bool,
    ) -> Self {
        let radiance = pixel_buffer(device, size, "rppm_radiance", 16, BufferUsages::COPY_SRC);
        Self {
            radiance,
            history: history.then(|| History::new(device, size, importons, demodulated)),
            outliers: importons.then(|| Outliers::new(device, size)),
            resolved: history.then(|| Resolved::new(device, size)),
            group: None,
        }
    }

    /// Bytes held besides the estimate: history, what is shown, outliers.
    pub fn memory(&self) -> Vec<(&'static str, u64)> {
        let history = self.history.as_ref().map(|h| ("history", h.bytes()));
        let shown = self.resolved.as_ref().map(|r| ("shown", r.shown.size()));
        let outliers = self.outliers.as_ref().map(|o| ("outliers", o.bytes()));
        [history, shown, outliers].into_iter().flatten().collect()
    }

    /// What the view shows and reads back: the estimate, or under `Reuse` its edges
    /// resolved after a camera move, in frames whose resolve ran (`resolved`).
    pub fn shown(&self, resolved: bool) -> &Buffer {
        let shown = self.resolved.as_ref().filter(|_| resolved);
        shown.map_or(&self.radiance, |r| &r.shown)
    }

    /// Binds this frame's sample, splats and G-buffer.
    pub fn bind(
        &mut self,
        device: &RenderDevice,
        cache: &PipelineCache,
        pipeline: &AccumulatePipeline,
        inputs: EstimateInputs,
    ) {
        let (samples, importons) = (&inputs.eye_paths.samples, &inputs.eye_paths.radiance);
        if let Some(outliers) = &mut self.outliers {
            outliers.bind(
                device,
                &cache.get_bind_group_layout(&pipeline.outliers.layout),
                inputs.params.clone(),
                inputs.eye_paths,
                &self.radiance,
                inputs.gbuffer,
            );
        }
        if let Some(resolved) = &mut self.resolved {
            let (gbuffer, radiance) = (inputs.gbuffer, &self.radiance);
            resolved.bind(device, cache, &pipeline.resolve, gbuffer, radiance);
        }
        let entries = BindGroupEntries::sequential((
            inputs.params,
            samples.as_entire_binding(),
            &inputs.splats.view,
            self.radiance.as_entire_binding(),
            importons.as_entire_binding(),
            &inputs.gbuffer.position,
            &inputs.gbuffer.normal,
        ));
        self.group = Some(match &self.history {
            None => device.create_bind_group(
                "rppm_accumulate_group",
                &cache.get_bind_group_layout(&pipeline.layout),
                &entries,
            ),
            Some(h) => {
                let [previous_radiance, previous_history] = h.previous_bindings();
                let history = BindGroupEntries::with_indices((
                    (7, h.history.as_entire_binding()),
                    (8, previous_radiance.as_entire_binding()),
                    (9, previous_history.as_entire_binding()),
                    (10, inputs.eye_paths.importons.as_entire_binding()),
                ));
                let all: Vec<_> = entries.iter().chain(history.iter()).cloned().collect();
                device.create_bind_group(
                    "rppm_accumulate_group",
                    &cache.get_bind_group_layout(&pipeline.history_layout),
                    &all,
                )
            }
        });
    }

    /// Keeps this frame's estimate and history as last frame's, for reprojection.
    pub fn encode_keep_previous(&self, encoder: &mut CommandEncoder) {
        if let Some(h) = &self.history {
            h.encode_keep(encoder, &self.radiance);
        }
    }

    /// Keeps the pixels' means since the change as last iteration's, for an iteration that
    /// clamps history to its neighbourhoods (`HistoryFlags::clamps`).
    pub fn encode_keep_fresh(&self, encoder: &mut CommandEncoder) {
        if let Some(h) = &self.history {
            h.encode_keep_fresh(encoder);
        }
    }

    /// Spreads outlying samples (with `outliers`' passes), adds the splats to the local
    /// sample and folds it into the running estimate.
    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &self,
        encoder: &mut CommandEncoder,
        outliers: Option<[&ComputePipeline; 2]>,
        pipeline: &ComputePipeline,
        scene_group: &BindGroup,
        size: UVec2,
        offset: u32,
        timer: &mut StageTimer,
    ) {
        let Some(group) = &self.group else { return };
        let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
            label: Some("rppm_accumulate"),
            timestamp_writes: timer.compute_pass(Stage::Accumulate),
        });
        if let (Some(own), Some(passes)) = (&self.outliers, outliers) {
            own.dispatch(&mut pass, passes, scene_group, size, offset);
        }
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, scene_group, &[]);
        pass.set_bind_group(1, group, &[offset]);
        pass.dispatch_workgroups(size.x.div_ceil(8), size.y.div_ceil(8), 1);
    }
}
