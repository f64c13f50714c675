//! What the render world reports back to the main world: per-camera stats (iterations, epoch,
//! GPU ms per stage, bytes held) and, on request, the raw radiance estimate; GPU timing,
//! read-backs and Bevy diagnostics.

pub mod diagnostics;
pub mod profile;
pub(crate) mod readback;
pub mod timing;

use std::collections::BTreeMap;

use bevy::platform::collections::HashMap;
use bevy::prelude::*;
use crossbeam_channel::{Receiver, Sender};
use serde::Serialize;

use crate::settings::PhotonMapping;

/// The main-world side of the reports: [`RppmStats`], [`RppmRadiance`] and the diagnostics.
pub(crate) struct StatsPlugin;

impl Plugin for StatsPlugin {
    fn build(&self, app: &mut App) {
        let (sender, receiver) = crossbeam_channel::unbounded();
        app.init_resource::<RppmStats>()
            .init_resource::<RppmRadiance>()
            .insert_resource(MainReceiver(receiver))
            .add_systems(PreUpdate, receive_reports);
        diagnostics::register(app);
        if let Some(render_app) = app.get_sub_app_mut(bevy::render::RenderApp) {
            render_app.insert_resource(RenderSender(sender));
        }
    }
}

/// One camera's radiance estimate, row-major from the top-left, RGBA (A = 1).
#[derive(Clone, Debug)]
pub struct RadianceImage {
    pub camera: Entity,
    pub width: u32,
    pub height: u32,
    /// Iterations averaged into `pixels`.
    pub iteration: u32,
    /// [`ViewStats::epoch`] when it was rendered: which state of the scene it shows.
    pub epoch: u64,
    pub pixels: Vec<[f32; 4]>,
}

/// One camera's progress and cost, as last reported by the render world.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ViewStats {
    /// Changes seen so far (the scene, the camera's settings and moves): the main world's
    /// `RppmScene::epoch` + `ViewEpoch::epoch` + `ViewEpoch::moves` when the render world saw
    /// them. Under `RppmHistory::Reset` a new epoch restarts accumulation.
    pub epoch: u64,
    /// Iterations accumulated since the last reset.
    pub iteration: u32,
    #[serde(rename = "iterations_last_frame")]
    pub iterations_this_frame: u32,
    /// Knaus–Zwicker gather radius of the next iteration, in pixels.
    pub splat_radius_pixels: f64,
    /// Whether the GPU has timestamp queries; without them `stage_ms` stays zero.
    pub gpu_timing: bool,
    /// GPU milliseconds per stage, summed over the iterations of the last timed frame.
    #[serde(rename = "gpu_ms_last_frame")]
    pub stage_ms: BTreeMap<String, f64>,
    /// GPU milliseconds per stage summed over every timed frame since the last reset of
    /// resources, and the iterations those frames ran.
    pub stage_ms_total: BTreeMap<String, f64>,
    pub timed_iterations: u64,
    /// CPU wall milliseconds per iteration and stage, each stage submitted alone and waited
    /// for (`PhotonMapping::profile_stages`; empty otherwise), since the last reset of
    /// resources.
    pub wall_ms_per_iteration: BTreeMap<String, f64>,
    /// Bytes held per buffer or texture.
    #[serde(rename = "memory_bytes")]
    pub memory: BTreeMap<String, u64>,
    pub adapter: String,
    /// Why nothing renders, when something failed (e.g. a pipeline did not build).
    pub error: Option<String>,
    /// Deep-cubemap list entries used by the last build read back, and entries that did not
    /// fit (the lists then grow for the next build).
    pub cubemap_nodes: u32,
    pub cubemap_overflow: u32,
    /// Photons emitted per iteration (0: the scene has nothing to emit them), and photons
    /// stored by the last iteration read back.
    pub photons_per_iteration: u32,
    pub photons_stored: u32,
    /// Photons that iteration found no room for in the store (which then grows): 0 but after
    /// a sudden change of the scene. The store is sized from these counts.
    pub photons_lost: u32,
    /// Importons (camera paths past specular surfaces) made by the last iteration read back.
    pub importons: u32,
    /// The passes each iteration runs: only those the scene and settings need.
    pub passes: Vec<String>,
    /// Scattering code paths compiled into the tracing stages, from the scene's materials
    /// (`GLOSSY`, `MIRRORS`, `REFRACTION`).
    pub shader_paths: Vec<String>,
    /// Bytes the scene's latest change sent to the GPU: what changed (a moved object: its
    /// instance, 128 bytes), not the scene.
    pub scene_upload_bytes: u64,
    /// Bytes of the scene's world-space triangles, made on the GPU (what re-uploading the
    /// geometry would send).
    pub scene_geometry_bytes: u64,
    /// CPU milliseconds of the scene's latest extraction in the main world.
    pub scene_extract_ms: f64,
    /// CPU milliseconds of the view's latest BVH update (`RppmTracer::Bvh`; 0 otherwise).
    pub bvh_build_ms: f64,
    /// Bytes the view's latest BVH update sent to the GPU: the levels of meshes that are new
    /// or posed anew, the level over the instances and their records (0 without a BVH).
    pub bvh_upload_bytes: u64,
}

/// Stats of every photon-mapping camera, by camera entity.
#[derive(Resource, Default, Debug)]
pub struct RppmStats {
    pub views: HashMap<Entity, ViewStats>,
}

/// Latest radiance read back per camera with [`RppmReadback`].
#[derive(Resource, Default, Debug)]
pub struct RppmRadiance {
    pub images: HashMap<Entity, RadianceImage>,
}

pub(crate) enum RenderMessage {
    Stats(Entity, Box<ViewStats>),
    Radiance(RadianceImage),
}

#[derive(Resource, Deref)]
pub(crate) struct RenderSender(pub Sender<RenderMessage>);

#[derive(Resource, Deref)]
struct MainReceiver(pub Receiver<RenderMessage>);

fn receive_reports(
    receiver: Res<MainReceiver>,
    mut stats: ResMut<RppmStats>,
    mut radiance: ResMut<RppmRadiance>,
    cameras: Query<(), With<PhotonMapping>>,
) {
    while let Ok(message) = receiver.try_recv() {
        match message {
            RenderMessage::Stats(entity, s) => {
                stats.views.insert(entity, *s);
            }
            RenderMessage::Radiance(image) => {
                radiance.images.insert(image.camera, image);
            }
        }
    }
    stats.views.retain(|e, _| cameras.contains(*e));
}
