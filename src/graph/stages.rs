//! The pipelines a view's stages run: every stage's pipeline and the caches of its variants,
//! and the variants a view's scene and settings pick.

use bevy::prelude::*;
use bevy::render::render_resource::*;

use super::state::{RppmViewState, StageIds, StagePipelines};
use crate::accumulate::{AccumulateKey, AccumulatePipeline, ResolveKey, ResolvePipeline};
use crate::cubemap::CubemapPipelines;
use crate::gbuffer::GBufferPipeline;
use crate::importons::{EyePathKey, EyePathPipeline};
use crate::indirect_splat::{IndirectSplatKey, IndirectSplatPipeline};
use crate::output::OutputPipeline;
use crate::photons::{PhotonKey, PhotonPipeline};
use crate::scene::{ScatterPaths, SceneBuffers};
use crate::shadows::ShadowPipeline;
use crate::splat::{SplatKey, SplatPipeline};
use crate::view::ViewLayouts;

/// Every stage's pipeline resource, and the caches of their variants.
#[derive(bevy::ecs::system::SystemParam)]
pub(crate) struct Pipelines<'w> {
    pub(super) cache: Res<'w, PipelineCache>,
    pub(super) layouts: Res<'w, ViewLayouts>,
    pub(super) shadow: Res<'w, ShadowPipeline>,
    pub(super) gbuffer: Res<'w, GBufferPipeline>,
    pub(super) gbuffer_variants: ResMut<'w, SpecializedRenderPipelines<GBufferPipeline>>,
    pub(super) cubemap: Res<'w, CubemapPipelines>,
    pub(super) eye_paths: Res<'w, EyePathPipeline>,
    pub(super) eye_path_variants: ResMut<'w, SpecializedComputePipelines<EyePathPipeline>>,
    pub(super) photons: Res<'w, PhotonPipeline>,
    pub(super) photon_variants: ResMut<'w, SpecializedComputePipelines<PhotonPipeline>>,
    pub(super) splat: Res<'w, SplatPipeline>,
    pub(super) splat_variants: ResMut<'w, SpecializedComputePipelines<SplatPipeline>>,
    pub(super) indirect_splat: Res<'w, IndirectSplatPipeline>,
    pub(super) indirect_splat_variants:
        ResMut<'w, SpecializedComputePipelines<IndirectSplatPipeline>>,
    pub(super) accumulate: Res<'w, AccumulatePipeline>,
    pub(super) accumulate_variants: ResMut<'w, SpecializedComputePipelines<AccumulatePipeline>>,
    pub(super) resolve_variants: ResMut<'w, SpecializedComputePipelines<ResolvePipeline>>,
    pub(super) output: Res<'w, OutputPipeline>,
    pub(super) output_variants: ResMut<'w, SpecializedRenderPipelines<OutputPipeline>>,
}

impl Pipelines<'_> {
    pub(super) fn stages(&self) -> StagePipelines<'_> {
        StagePipelines {
            layouts: &self.layouts,
            eye_paths: &self.eye_paths,
            photons: &self.photons,
            splat: &self.splat,
            indirect_splat: &self.indirect_splat,
            accumulate: &self.accumulate,
            output: &self.output,
        }
    }

    /// Whether the pipelines every view runs are compiled, or the first that failed.
    pub(super) fn shared_ready(&self) -> Result<bool, String> {
        readiness([self.cache.get_render_pipeline_state(self.shadow.0)])
    }
}

/// The variants of the stages this view runs: only the scattering paths its scene's
/// materials have, importons only when camera paths go on.
pub(super) fn select_stages(
    state: &RppmViewState,
    scene: &SceneBuffers,
    output: Option<crate::output::OutputKey>,
    pipelines: &mut Pipelines,
) -> StageIds {
    let cache = &pipelines.cache;
    let traced = state.photons > 0 && state.cubemap.cubemap.is_some();
    let subsampled = state.key.subsampling > 1;
    let lookups = scene.lookups;
    let mut layers = scene.paths & ScatterPaths::LAYERS;
    // Without camera paths past the first hit (eye depth 1, a target too large for their
    // buffers) no path follows a sharp glossy lobe: the first hit gathers it too.
    layers.set(
        ScatterPaths::GLOSSY_TRACED,
        layers.contains(ScatterPaths::GLOSSY_TRACED) && state.importons,
    );
    let emitters = !scene.data.emitters.is_empty();
    // Light that is drawn (sampled), not exact at a point: emissive surfaces, a sky, spheres.
    let sampled_lights =
        emitters || scene.paths.contains(ScatterPaths::SKY) || scene.data.has_sphere_lights();
    let exact_direct = !sampled_lights && scene.data.lights.len() <= crate::shadows::MANY_LIGHTS;
    // Shadow rays drawn toward them.
    let traced_emitters = emitters && state.traced_shadows;
    // Camera paths go on past the G-buffer and trace their shadow rays.
    let paths_lit = state.importons && state.traced_shadows;
    StageIds {
        gbuffer: pipelines
            .gbuffer_variants
            .specialize(cache, &pipelines.gbuffer, lookups),
        eye_paths: pipelines.eye_path_variants.specialize(
            cache,
            &pipelines.eye_paths,
            EyePathKey {
                importons: state.importons.then_some(scene.paths),
                traced_shadows: state.traced_shadows,
                lookups,
                sky: scene.paths.contains(ScatterPaths::SKY),
                layers,
                bvh: state.key.bvh,
                light_guide: paths_lit
                    && scene.paths.contains(ScatterPaths::ROUGH_REFRACTION)
                    && !scene.data.lights.is_empty(),
                sphere_lights: paths_lit && scene.sphere_lights,
                spheres_seen: scene.data.has_sphere_lights(),
                reflected_emission: state.importons
                    && scene.paths.contains(ScatterPaths::REFRACTION)
                    && sampled_lights,
                emitters: traced_emitters,
                emitter_rays: traced_emitters && scene.many_faced_emitters,
                shading_points: state.key.history && state.traced_shadows,
            },
        ),
        trace: traced.then(|| {
            pipelines.photon_variants.specialize(
                cache,
                &pipelines.photons,
                PhotonKey {
                    paths: scene.paths,
                    lookups,
                    bvh: state.key.bvh,
                },
            )
        }),
        sort: traced.then_some(pipelines.photons.sort.passes),
        splat: traced.then(|| {
            pipelines.splat_variants.specialize(
                cache,
                &pipelines.splat,
                SplatKey {
                    subsampled,
                    lookups,
                    layers,
                    glass: scene.paths.intersects(ScatterPaths::GLASS),
                    adaptive_kernel: state.key.adaptive_kernel,
                },
            )
        }),
        indirect_splat: (traced && state.importons).then(|| {
            pipelines.indirect_splat_variants.specialize(
                cache,
                &pipelines.indirect_splat,
                IndirectSplatKey {
                    lookups,
                    layers,
                    bvh: state.key.bvh,
                    glass: scene.paths.intersects(ScatterPaths::GLASS),
                    adaptive_kernel: state.key.adaptive_kernel,
                },
            )
        }),
        accumulate: pipelines.accumulate_variants.specialize(
            cache,
            &pipelines.accumulate,
            AccumulateKey {
                subsampled,
                importons: state.importons,
                lookups,
                layers,
                history: state.key.history,
                emitters: emitters && state.key.history,
                exact_direct: state.key.history && exact_direct,
                demodulated: state.key.history && state.key.textured,
            },
        ),
        resolve: (state.key.history && state.cubemap.cubemap.is_some()).then(|| {
            pipelines.resolve_variants.specialize(
                cache,
                &pipelines.accumulate.resolve,
                ResolveKey {
                    lookups,
                    bvh: state.key.bvh,
                },
            )
        }),
        outliers: state
            .importons
            .then_some(pipelines.accumulate.outliers.passes),
        output: output.map(|key| {
            pipelines
                .output_variants
                .specialize(cache, &pipelines.output, key)
        }),
    }
}

/// Whether every pipeline is compiled; an error when one failed to build.
pub(super) fn readiness<'a>(
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
pub(super) fn stages_ready(state: &RppmViewState, cache: &PipelineCache) -> Result<bool, String> {
    let Some(stages) = state.stages else {
        return Ok(false);
    };
    let compute = [
        Some(stages.eye_paths),
        Some(stages.accumulate),
        stages.trace,
        stages.splat,
        stages.indirect_splat,
    ];
    let sort = (stages.sort.into_iter().flatten())
        .chain(stages.outliers.into_iter().flatten())
        .map(Some);
    let render = [cache.get_render_pipeline_state(stages.gbuffer)];
    readiness(
        compute
            .into_iter()
            .chain(sort)
            .flatten()
            .map(|id| cache.get_compute_pipeline_state(id))
            .chain(render),
    )
}
