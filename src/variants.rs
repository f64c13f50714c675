//! Pipelines queued the first time a set of shader defs is asked for, so that a scene compiles
//! and runs only the code paths it contains (no glass: no refraction branch; the defs come
//! from `SceneData::path_features`).

use bevy::platform::collections::HashMap;
use bevy::render::render_resource::{
    CachedComputePipelineId, CachedRenderPipelineId, ComputePipelineDescriptor, PipelineCache,
    RenderPipelineDescriptor,
};

use bevy::shader::ShaderDefVal;

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
