//! A camera's settings into the render world, and the change counter that restarts its
//! estimate when the camera moves, its projection or target changes, or its settings do.

use bevy::ecs::query::QueryItem;
use bevy::prelude::*;
use bevy::render::extract_component::ExtractComponent;
use bevy::render::sync_component::SyncComponent;

use crate::settings::{PhotonMapping, RppmFastForward, RppmReadback, ViewEpoch, ViewKey};

/// The camera's settings and change counter, in the render world.
#[derive(Component, Clone)]
pub struct ExtractedRppm {
    pub settings: PhotonMapping,
    pub view_epoch: u64,
    pub view_moves: u64,
    pub readback: bool,
    pub fast_forward: Option<u32>,
}

impl SyncComponent for PhotonMapping {
    type Target = ExtractedRppm;
}

impl ExtractComponent for PhotonMapping {
    type QueryData = (
        &'static PhotonMapping,
        &'static ViewEpoch,
        Has<RppmReadback>,
        Option<&'static RppmFastForward>,
    );
    type QueryFilter = ();
    type Out = ExtractedRppm;

    fn extract_component(
        (settings, epoch, readback, fast_forward): QueryItem<'_, '_, Self::QueryData>,
    ) -> Option<ExtractedRppm> {
        settings.enabled.then(|| ExtractedRppm {
            settings: settings.clone(),
            view_epoch: epoch.epoch,
            view_moves: epoch.moves,
            readback,
            fast_forward: fast_forward.map(|f| f.0),
        })
    }
}

/// Advances a camera's [`ViewEpoch`] when its settings or target size changed, and its moves
/// when its transform or projection did.
pub(super) fn track_view_changes(
    mut cameras: Query<(
        &mut ViewEpoch,
        &Camera,
        &GlobalTransform,
        Ref<PhotonMapping>,
    )>,
) {
    for (mut view, camera, transform, settings) in &mut cameras {
        let key = ViewKey {
            world_from_view: transform.to_matrix(),
            clip_from_view: camera.clip_from_view(),
        };
        let target = Some(camera.physical_target_size());
        if view.target != target || settings.is_changed() {
            view.target = target;
            view.epoch += 1;
        }
        if view.key != Some(key) {
            view.key = Some(key);
            view.moves += 1;
        }
    }
}
