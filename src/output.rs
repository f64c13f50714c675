//! What the render world reports back to the main world: per-camera stats (iterations, epoch,
//! GPU ms per stage, bytes held) and, on request, the raw radiance estimate.

use std::collections::BTreeMap;

use bevy::platform::collections::HashMap;
use bevy::prelude::*;
use bevy::render::render_resource::{
    Buffer, BufferDescriptor, BufferUsages, CommandEncoder, CommandEncoderDescriptor, MapMode,
    PollType,
};
use bevy::render::renderer::{RenderDevice, RenderQueue};
use crossbeam_channel::{Receiver, Sender};
use serde::Serialize;

use crate::cubemap::bench::{DirtBenchResults, DirtBenchRow};

/// Add to a `PhotonMapping` camera to receive its raw linear radiance (no exposure, no
/// tonemapping) in [`RppmRadiance`] every frame. Each read-back waits for the GPU, so add it
/// only when you need the pixels.
#[derive(Component, Reflect, Clone, Copy, Debug, Default)]
#[reflect(Component, Default)]
pub struct RppmReadback;

/// One camera's radiance estimate, row-major from the top-left, RGBA (A = 1).
#[derive(Clone, Debug)]
pub struct RadianceImage {
    pub camera: Entity,
    pub width: u32,
    pub height: u32,
    /// Iterations averaged into `pixels`.
    pub iteration: u32,
    pub epoch: u64,
    pub pixels: Vec<[f32; 4]>,
}

/// One camera's progress and cost, as last reported by the render world.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ViewStats {
    /// Changes seen so far (scene and view); a new epoch restarts accumulation.
    pub epoch: u64,
    /// Iterations accumulated since the last reset.
    pub iteration: u32,
    pub iterations_this_frame: u32,
    /// Knaus–Zwicker gather radius of the next iteration, in pixels.
    pub splat_radius_pixels: f64,
    /// Whether the GPU has timestamp queries; without them `stage_ms` stays zero.
    pub gpu_timing: bool,
    /// GPU milliseconds per stage, summed over the iterations of the last timed frame.
    pub stage_ms: BTreeMap<String, f64>,
    /// GPU milliseconds per stage summed over every timed frame since the last reset of
    /// resources, and the iterations those frames ran.
    pub stage_ms_total: BTreeMap<String, f64>,
    pub timed_iterations: u64,
    /// Bytes held per buffer or texture.
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
    /// Importons (camera paths past specular surfaces) made by the last iteration read back.
    pub importons: u32,
    /// The passes each iteration runs: only those the scene and settings need.
    pub passes: Vec<String>,
    /// Scattering code paths compiled into the tracing stages, from the scene's materials
    /// (`GLOSSY`, `MIRRORS`, `REFRACTION`).
    pub shader_paths: Vec<String>,
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
    Stats(Entity, ViewStats),
    Radiance(RadianceImage),
    DirtBench(Vec<DirtBenchRow>),
}

/// Copies a GPU buffer (with `COPY_SRC`) back to the CPU, waiting for the GPU.
pub(crate) fn read_back(
    device: &RenderDevice,
    queue: &RenderQueue,
    source: &Buffer,
) -> Option<Vec<u8>> {
    let staging = device.create_buffer(&BufferDescriptor {
        label: Some("rppm_read_back"),
        size: source.size(),
        usage: BufferUsages::MAP_READ | BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&CommandEncoderDescriptor::default());
    encoder.copy_buffer_to_buffer(source, 0, &staging, 0, source.size());
    queue.submit([encoder.finish()]);
    let slice = staging.slice(..);
    let (tx, rx) = crossbeam_channel::bounded(1);
    slice.map_async(MapMode::Read, move |r| {
        let _ = tx.send(r.is_ok());
    });
    device.poll(PollType::wait_indefinitely()).ok()?;
    if !rx.recv().ok()? {
        return None;
    }
    let bytes = slice.get_mapped_range().to_vec();
    staging.unmap();
    Some(bytes)
}

/// A non-blocking read-back of a small buffer: copied after the passes that write it, mapped
/// once submitted, read in a later frame when the GPU is done, so no frame waits for it.
pub(crate) struct AsyncReadback {
    staging: Buffer,
    state: std::sync::Mutex<Probe>,
}

#[derive(Default)]
enum Probe {
    #[default]
    Idle,
    Copied,
    /// 0 while mapping, 1 mapped, 2 failed.
    Mapping(std::sync::Arc<std::sync::atomic::AtomicU8>),
}

impl AsyncReadback {
    pub fn new(device: &RenderDevice, size: u64) -> Self {
        let staging = device.create_buffer(&BufferDescriptor {
            label: Some("rppm_async_read_back"),
            size,
            usage: BufferUsages::MAP_READ | BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            staging,
            state: default(),
        }
    }

    /// Records a copy of `source`, unless an earlier copy is still on its way back.
    pub fn encode_copy(&self, encoder: &mut CommandEncoder, source: &Buffer) {
        let Ok(mut state) = self.state.lock() else {
            return;
        };
        if matches!(*state, Probe::Idle) {
            encoder.copy_buffer_to_buffer(source, 0, &self.staging, 0, self.staging.size());
            *state = Probe::Copied;
        }
    }

    /// After submission: starts mapping the last copy, or returns its bytes once mapped.
    pub fn poll(&self, device: &RenderDevice) -> Option<Vec<u8>> {
        use std::sync::atomic::{AtomicU8, Ordering};
        let mut state = self.state.lock().ok()?;
        match &*state {
            Probe::Idle => None,
            Probe::Copied => {
                let flag = std::sync::Arc::new(AtomicU8::new(0));
                let done = flag.clone();
                self.staging.slice(..).map_async(MapMode::Read, move |r| {
                    done.store(if r.is_ok() { 1 } else { 2 }, Ordering::Release);
                });
                *state = Probe::Mapping(flag);
                None
            }
            Probe::Mapping(flag) => {
                let _ = device.poll(PollType::Poll);
                match flag.load(Ordering::Acquire) {
                    0 => None,
                    1 => {
                        let bytes = self.staging.slice(..).get_mapped_range().to_vec();
                        self.staging.unmap();
                        *state = Probe::Idle;
                        Some(bytes)
                    }
                    _ => {
                        *state = Probe::Idle;
                        None
                    }
                }
            }
        }
    }
}

#[derive(Resource, Deref)]
pub(crate) struct RenderSender(pub Sender<RenderMessage>);

#[derive(Resource, Deref)]
pub(crate) struct MainReceiver(pub Receiver<RenderMessage>);

pub(crate) fn receive_reports(
    receiver: Res<MainReceiver>,
    mut stats: ResMut<RppmStats>,
    mut radiance: ResMut<RppmRadiance>,
    mut bench: ResMut<DirtBenchResults>,
    cameras: Query<(), With<crate::PhotonMapping>>,
) {
    while let Ok(message) = receiver.try_recv() {
        match message {
            RenderMessage::Stats(entity, s) => {
                stats.views.insert(entity, s);
            }
            RenderMessage::Radiance(image) => {
                radiance.images.insert(image.camera, image);
            }
            RenderMessage::DirtBench(rows) => bench.0 = Some(Ok(rows)),
        }
    }
    stats.views.retain(|e, _| cameras.contains(*e));
}
