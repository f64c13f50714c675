//! What every stage of a camera's iteration shares: the camera's settings in the render world
//! ([`ExtractedRppm`]), the per-iteration constants ([`IterationParams`]) and the bind group
//! layouts of the scene and of those constants.

mod extract;
pub mod layouts;
pub mod params;

use bevy::camera::visibility::VisibilitySystems;
use bevy::prelude::*;
use bevy::render::RenderApp;
use bevy::render::extract_component::ExtractComponentPlugin;
use bevy::render::render_resource::{Buffer, BufferDescriptor, BufferUsages};
use bevy::render::renderer::RenderDevice;
use bevy::transform::TransformSystems;

pub use extract::ExtractedRppm;
pub use layouts::ViewLayouts;
pub use params::{IterationParams, PARAMS_STRIDE};

use crate::settings::{PhotonMapping, RppmReadback, validate_settings};

/// Settings validation and change tracking in the main world, extraction into the render
/// world, and the shared layouts.
pub(crate) struct ViewPlugin;

impl Plugin for ViewPlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<PhotonMapping>()
            .register_type::<RppmReadback>()
            .add_plugins(ExtractComponentPlugin::<PhotonMapping>::default())
            .add_systems(
                PostUpdate,
                (
                    validate_settings,
                    extract::track_view_changes
                        .after(TransformSystems::Propagate)
                        .after(VisibilitySystems::VisibilityPropagate)
                        .after(bevy::camera::CameraUpdateSystems),
                )
                    .chain(),
            );
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app.init_resource::<ViewLayouts>();
        }
    }
}

/// The bytes one buffer binding of `device` may hold (llvmpipe: 128 MiB).
pub(crate) fn binding_limit(device: &RenderDevice) -> u64 {
    let limits = device.limits();
    limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size)
}

/// A storage buffer of `bytes_per_pixel` for each pixel of `size`.
pub(crate) fn pixel_buffer(
    device: &RenderDevice,
    size: UVec2,
    label: &'static str,
    bytes_per_pixel: u64,
    usage: BufferUsages,
) -> Buffer {
    device.create_buffer(&BufferDescriptor {
        label: Some(label),
        size: size.x as u64 * size.y as u64 * bytes_per_pixel,
        usage: BufferUsages::STORAGE | usage,
        mapped_at_creation: false,
    })
}

/// Whether `what`, a buffer of `bytes_per_pixel` for each of `size`'s pixels bound whole,
/// fits [`binding_limit`]; `Err` says by how much it does not.
pub(crate) fn per_pixel_binding_fits(
    device: &RenderDevice,
    size: UVec2,
    bytes_per_pixel: u64,
    what: &str,
) -> Result<(), String> {
    let (bytes, most) = (
        size.x as u64 * size.y as u64 * bytes_per_pixel,
        binding_limit(device),
    );
    if bytes <= most {
        return Ok(());
    }
    Err(format!(
        "a {}x{} target's {what} needs {} MiB in one binding, over this device's {} MiB",
        size.x,
        size.y,
        bytes >> 20,
        most >> 20
    ))
}
