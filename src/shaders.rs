//! Our WGSL, compiled into the crate and added to `Assets<Shader>` when the plugin is built.
//! The files live under the top-level `shaders/<stage>/`, one folder per pipeline stage.

use bevy::prelude::*;
use bevy::shader::Shader;

macro_rules! wgsl {
    ($shaders:expr, $name:literal) => {
        $shaders.add(Shader::from_wgsl(
            include_str!(concat!("../shaders/", $name)),
            concat!("bevy_rppm/shaders/", $name),
        ))
    };
}

/// Handles of every stage's shader.
#[derive(Resource, Clone)]
pub struct RppmShaders {
    /// Import-only libraries (`bevy_rppm::sampling`, `common`, `camera`, `scene`, `microfacet`, `bsdf`, `mis`, `panes`, `cubemap`, `pane_rays`, `light_samples`, `lighting`,
    /// `photon_map`, `eye_bounce`, `footprint`, `surface`, `reproject`),
    /// held so they stay loaded.
    _libraries: Vec<Handle<Shader>>,
    pub place: Handle<Shader>,
    pub shadow_map: Handle<Shader>,
    pub gbuffer: Handle<Shader>,
    pub cubemap_build: Handle<Shader>,
    pub bvh_fill: Handle<Shader>,
    pub eye_paths: Handle<Shader>,
    pub photon_trace: Handle<Shader>,
    pub photon_sort: Handle<Shader>,
    pub splat: Handle<Shader>,
    pub indirect_splat: Handle<Shader>,
    pub accumulate: Handle<Shader>,
    pub outliers: Handle<Shader>,
    pub resolve: Handle<Shader>,
    pub output: Handle<Shader>,
    #[cfg(feature = "debug")]
    pub debug_view: Handle<Shader>,
    #[cfg(feature = "debug")]
    pub cubemap_bench: Handle<Shader>,
    #[cfg(feature = "debug")]
    pub furnace: Handle<Shader>,
}

impl RppmShaders {
    pub fn load(shaders: &mut Assets<Shader>) -> Self {
        Self {
            _libraries: vec![
                wgsl!(shaders, "common/sampling.wgsl"),
                wgsl!(shaders, "common/common.wgsl"),
                wgsl!(shaders, "common/camera.wgsl"),
                wgsl!(shaders, "common/microfacet.wgsl"),
                wgsl!(shaders, "common/bsdf.wgsl"),
                wgsl!(shaders, "common/mis.wgsl"),
                wgsl!(shaders, "common/panes.wgsl"),
                wgsl!(shaders, "scene/scene.wgsl"),
                wgsl!(shaders, "cubemap/trace.wgsl"),
                wgsl!(shaders, "shadows/panes.wgsl"),
                wgsl!(shaders, "shadows/light_samples.wgsl"),
                wgsl!(shaders, "shadows/lighting.wgsl"),
                wgsl!(shaders, "photons/map.wgsl"),
                wgsl!(shaders, "importons/bounce.wgsl"),
                wgsl!(shaders, "importons/footprint.wgsl"),
                wgsl!(shaders, "scene/surface.wgsl"),
                wgsl!(shaders, "accumulate/reproject.wgsl"),
            ],
            place: wgsl!(shaders, "scene/place.wgsl"),
            shadow_map: wgsl!(shaders, "shadows/shadow_map.wgsl"),
            gbuffer: wgsl!(shaders, "gbuffer/gbuffer.wgsl"),
            cubemap_build: wgsl!(shaders, "cubemap/build.wgsl"),
            bvh_fill: wgsl!(shaders, "cubemap/bvh_fill.wgsl"),
            eye_paths: wgsl!(shaders, "importons/eye_paths.wgsl"),
            photon_trace: wgsl!(shaders, "photons/trace.wgsl"),
            photon_sort: wgsl!(shaders, "photons/sort.wgsl"),
            splat: wgsl!(shaders, "splat/splat.wgsl"),
            indirect_splat: wgsl!(shaders, "indirect_splat/indirect_splat.wgsl"),
            accumulate: wgsl!(shaders, "accumulate/accumulate.wgsl"),
            outliers: wgsl!(shaders, "accumulate/outliers.wgsl"),
            resolve: wgsl!(shaders, "accumulate/resolve.wgsl"),
            output: wgsl!(shaders, "output/output.wgsl"),
            #[cfg(feature = "debug")]
            debug_view: wgsl!(shaders, "debug/debug_view.wgsl"),
            #[cfg(feature = "debug")]
            cubemap_bench: wgsl!(shaders, "debug/cubemap_bench.wgsl"),
            #[cfg(feature = "debug")]
            furnace: wgsl!(shaders, "debug/furnace.wgsl"),
        }
    }
}
