//! GPU buffers back to the CPU: blocking (frames that wait for the GPU anyway) and
//! non-blocking (small counters every frame, without a stall).

use bevy::prelude::*;
use bevy::render::render_resource::{
    Buffer, BufferDescriptor, BufferUsages, CommandEncoder, CommandEncoderDescriptor, MapMode,
    PollType,
};
use bevy::render::renderer::{RenderDevice, RenderQueue};

/// Copies a GPU buffer (with `COPY_SRC`) back to the CPU, waiting for the GPU.
pub fn read_back(device: &RenderDevice, queue: &RenderQueue, source: &Buffer) -> Option<Vec<u8>> {
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
pub struct AsyncReadback {
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

    /// Records a copy of `source`, unless an earlier copy is still on its way back; whether
    /// it did.
    pub fn encode_copy(&self, encoder: &mut CommandEncoder, source: &Buffer) -> bool {
        let Ok(mut state) = self.state.lock() else {
            return false;
        };
        let idle = matches!(*state, Probe::Idle);
        if idle {
            encoder.copy_buffer_to_buffer(source, 0, &self.staging, 0, self.staging.size());
            *state = Probe::Copied;
        }
        idle
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
