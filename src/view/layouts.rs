//! The bind group layouts every stage shares: the scene tables (group 0) and this
//! iteration's constants (group 1, at a dynamic offset).

use std::num::NonZeroU64;

use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{
    storage_buffer_read_only_sized, storage_buffer_sized, texture_2d, uniform_buffer_sized,
};
use bevy::render::render_resource::*;

use super::params::IterationParams;

/// Layouts of the groups every stage binds.
#[derive(Resource, Clone)]
pub struct ViewLayouts {
    /// 0 triangles, 1 shadow views, 2 materials, 3 lights, 4 emitters, 5 light CDF, 6 the
    /// GGX albedo table ([`crate::bsdf`]), 7 triangle attributes, 8 textures, 9 texels.
    pub scene: BindGroupLayoutDescriptor,
    /// 0 per-iteration params (dynamic offset), 1 how far the camera sees (compute only:
    /// local illumination counts it, photon emission follows it; `SEEN_REGION_BYTES`).
    pub params: BindGroupLayoutDescriptor,
}

/// The uniform binding of [`IterationParams`], at a dynamic offset.
pub fn params_entry() -> BindGroupLayoutEntryBuilder {
    uniform_buffer_sized(true, NonZeroU64::new(size_of::<IterationParams>() as u64))
}

impl Default for ViewLayouts {
    fn default() -> Self {
        let all = ShaderStages::VERTEX | ShaderStages::FRAGMENT | ShaderStages::COMPUTE;
        let read = || storage_buffer_read_only_sized(false, None);
        Self {
            scene: BindGroupLayoutDescriptor::new(
                "rppm_scene_layout",
                &BindGroupLayoutEntries::sequential(
                    all,
                    (
                        read(),
                        read(),
                        texture_2d(TextureSampleType::Uint),
                        read(),
                        read(),
                        read(),
                        texture_2d(TextureSampleType::Float { filterable: false }),
                        read(),
                        read(),
                        read(),
                    ),
                ),
            ),
            params: BindGroupLayoutDescriptor::new(
                "rppm_params_layout",
                &BindGroupLayoutEntries::sequential(
                    all,
                    (
                        params_entry(),
                        storage_buffer_sized(false, None).visibility(ShaderStages::COMPUTE),
                    ),
                ),
            ),
        }
    }
}
