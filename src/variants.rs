//! Pipelines queued the first time a set of shader defs is asked for, so that a scene compiles
//! and runs only the code paths it contains (no glass: no refraction branch).

use bevy::platform::collections::HashMap;
use bevy::render::render_resource::{
    CachedComputePipelineId, CachedRenderPipelineId, ComputePipelineDescriptor, PipelineCache,
    RenderPipelineDescriptor,
};

use bevy::shader::ShaderDefVal;

use crate::scene::SceneData;

/// A pipeline descriptor that can be queued with extra shader defs.
pub trait Variant: Clone {
    type Id: Copy;
    fn queue(&self, cache: &PipelineCache, defs: &[&'static str]) -> Self::Id;
}

fn with_defs(base: &[ShaderDefVal], defs: &[&'static str]) -> Vec<ShaderDefVal> {
    let extra = defs.iter().map(|&d| ShaderDefVal::from(d));
    base.iter().cloned().chain(extra).collect()
}

impl Variant for ComputePipelineDescriptor {
    type Id = CachedComputePipelineId;
    fn queue(&self, cache: &PipelineCache, defs: &[&'static str]) -> Self::Id {
        let mut descriptor = self.clone();
        descriptor.shader_defs = with_defs(&self.shader_defs, defs);
        cache.queue_compute_pipeline(descriptor)
    }
}

impl Variant for RenderPipelineDescriptor {
    type Id = CachedRenderPipelineId;
    fn queue(&self, cache: &PipelineCache, defs: &[&'static str]) -> Self::Id {
        let mut descriptor = self.clone();
        descriptor.vertex.shader_defs = with_defs(&self.vertex.shader_defs, defs);
        if let Some(fragment) = &mut descriptor.fragment {
            fragment.shader_defs = with_defs(&fragment.shader_defs, defs);
        }
        cache.queue_render_pipeline(descriptor)
    }
}

/// One descriptor and the variants of it queued so far, by their shader defs.
pub struct Variants<D: Variant> {
    base: D,
    ids: HashMap<Vec<&'static str>, D::Id>,
}

impl<D: Variant> Variants<D> {
    pub fn new(base: D) -> Self {
        Self {
            base,
            ids: HashMap::default(),
        }
    }

    /// The variant with these defs, queued now if it never was.
    pub fn get(&mut self, cache: &PipelineCache, defs: &[&'static str]) -> D::Id {
        *self
            .ids
            .entry(defs.to_vec())
            .or_insert_with(|| self.base.queue(cache, defs))
    }
}

/// Which scattering code paths the scene's materials need (shader defs of the tracing stages).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct PathFeatures {
    /// A rough GGX lobe (any material with a specular layer and roughness ≥ 0.02).
    pub glossy: bool,
    /// Perfect mirrors (smooth metals).
    pub mirrors: bool,
    /// Smooth glass (transmission on a smooth dielectric).
    pub refraction: bool,
}

/// Below this perceptual roughness a lobe is a delta (`DELTA_ROUGHNESS` in bsdf.wgsl).
const DELTA_ROUGHNESS: f32 = 0.02;

impl PathFeatures {
    pub fn of(scene: &SceneData) -> Self {
        let mut features = Self::default();
        for m in &scene.materials {
            let colour = m.base_color[..3].iter().any(|&c| c > 0.0);
            if m.perceptual_roughness >= DELTA_ROUGHNESS {
                features.glossy |= m.reflectance > 0.0 || (m.metallic > 0.0 && colour);
            } else {
                features.mirrors |= m.metallic > 0.0 && colour;
                features.refraction |= m.specular_transmission * (1.0 - m.metallic) > 0.0;
            }
        }
        features
    }

    /// The shader defs naming these paths.
    pub fn defs(self) -> Vec<&'static str> {
        [
            (self.glossy, "GLOSSY"),
            (self.mirrors, "MIRRORS"),
            (self.refraction, "REFRACTION"),
        ]
        .into_iter()
        .filter_map(|(on, def)| on.then_some(def))
        .collect()
    }
}
