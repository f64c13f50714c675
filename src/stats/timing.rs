//! GPU time per pipeline stage from timestamp queries, read back without stalling the frame.

use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

use bevy::render::render_resource::*;
use bevy::render::renderer::{RenderDevice, RenderQueue};
use wgpu::{
    ComputePassTimestampWrites, QuerySet, QuerySetDescriptor, QueryType, RenderPassTimestampWrites,
};

/// The stages of one PPM iteration that report GPU time.
pub const STAGES: usize = 11;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Stage {
    ShadowMaps,
    GBuffer,
    LocalIllumination,
    Output,
    CubemapBuild,
    CubemapTrace,
    PhotonTrace,
    PhotonSort,
    Splat,
    IndirectSplat,
    Accumulate,
}

impl Stage {
    pub const ALL: [Stage; STAGES] = [
        Stage::ShadowMaps,
        Stage::GBuffer,
        Stage::LocalIllumination,
        Stage::Output,
        Stage::CubemapBuild,
        Stage::CubemapTrace,
        Stage::PhotonTrace,
        Stage::PhotonSort,
        Stage::Splat,
        Stage::IndirectSplat,
        Stage::Accumulate,
    ];

    /// Its place in [`Stage::ALL`] and in per-stage arrays.
    pub fn index(self) -> usize {
        self as usize
    }

    pub fn name(self) -> &'static str {
        match self {
            Stage::ShadowMaps => "shadow_maps",
            Stage::GBuffer => "gbuffer",
            Stage::LocalIllumination => "local_illumination",
            Stage::Output => "output",
            Stage::CubemapBuild => "cubemap_build",
            Stage::CubemapTrace => "cubemap_trace",
            Stage::PhotonTrace => "photon_trace",
            Stage::PhotonSort => "photon_sort",
            Stage::Splat => "splat",
            Stage::IndirectSplat => "indirect_splat",
            Stage::Accumulate => "accumulate",
        }
    }
}

/// What a timed frame ran: its iterations, and the photons each emitted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameWork {
    pub iterations: u32,
    pub photons: u32,
}

/// Timestamp pairs around each pass of a frame, summed per stage once the GPU is done.
pub struct StageTimer {
    query_set: Option<QuerySet>,
    capacity: u32,
    used: u32,
    spans: Vec<Stage>,
    resolve: Option<Buffer>,
    readback: Option<Buffer>,
    /// Spans of the frame whose timestamps are being mapped, its iterations and photons per
    /// iteration, and the map's state (`PENDING`, `MAPPED` or `FAILED`).
    in_flight: Option<(Vec<Stage>, FrameWork, Arc<AtomicU8>)>,
    /// The work of the frame being recorded.
    frame: FrameWork,
    copied: bool,
    period_ns: f32,
    /// GPU ms per stage of the last frame read back.
    pub last_ms: [f64; STAGES],
    /// The work of that frame.
    pub last_frame: FrameWork,
    /// GPU ms per stage summed over every frame read back since the timer was made.
    pub total_ms: [f64; STAGES],
    /// Iterations in the frames summed into `total_ms`.
    pub timed_iterations: u64,
}

const PENDING: u8 = 0;
const MAPPED: u8 = 1;
const FAILED: u8 = 2;

impl StageTimer {
    /// A timer with room for `capacity / 2` passes a frame; inert when the device lacks
    /// timestamp queries.
    pub fn new(device: &RenderDevice, queue: &RenderQueue, capacity: u32) -> Self {
        let supported = device.features().contains(WgpuFeatures::TIMESTAMP_QUERY);
        let capacity = capacity.clamp(2, 4096) & !1;
        let (query_set, resolve, readback) = if supported {
            let bytes = capacity as u64 * 8;
            (
                Some(device.wgpu_device().create_query_set(&QuerySetDescriptor {
                    label: Some("rppm_timestamps"),
                    ty: QueryType::Timestamp,
                    count: capacity,
                })),
                Some(device.create_buffer(&BufferDescriptor {
                    label: Some("rppm_timestamps_resolve"),
                    size: bytes,
                    usage: BufferUsages::QUERY_RESOLVE | BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                })),
                Some(device.create_buffer(&BufferDescriptor {
                    label: Some("rppm_timestamps_readback"),
                    size: bytes,
                    usage: BufferUsages::MAP_READ | BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })),
            )
        } else {
            (None, None, None)
        };
        Self {
            query_set,
            capacity,
            used: 0,
            spans: Vec::new(),
            resolve,
            readback,
            in_flight: None,
            copied: false,
            period_ns: queue.get_timestamp_period(),
            last_ms: [0.0; STAGES],
            total_ms: [0.0; STAGES],
            timed_iterations: 0,
            frame: FrameWork::default(),
            last_frame: FrameWork::default(),
        }
    }

    pub fn supported(&self) -> bool {
        self.query_set.is_some()
    }

    /// Starts a frame; timing is skipped while the previous read-back is still mapped.
    pub fn begin_frame(&mut self, frame: FrameWork) {
        self.frame = frame;
        self.used = 0;
        self.spans.clear();
        self.copied = false;
    }

    /// A begin/end query pair for one pass of `stage`, or `None` when timing is off or full.
    fn allocate(&mut self, stage: Stage) -> Option<(&QuerySet, u32)> {
        let query_set = self.query_set.as_ref()?;
        if self.in_flight.is_some() || self.used + 2 > self.capacity {
            return None;
        }
        let begin = self.used;
        self.used += 2;
        self.spans.push(stage);
        Some((query_set, begin))
    }

    /// Timestamp writes around one render pass of `stage`.
    pub fn render_pass(&mut self, stage: Stage) -> Option<RenderPassTimestampWrites<'_>> {
        self.allocate(stage)
            .map(|(query_set, begin)| RenderPassTimestampWrites {
                query_set,
                beginning_of_pass_write_index: Some(begin),
                end_of_pass_write_index: Some(begin + 1),
            })
    }

    /// Timestamp writes around one compute pass of `stage`.
    pub fn compute_pass(&mut self, stage: Stage) -> Option<ComputePassTimestampWrites<'_>> {
        self.allocate(stage)
            .map(|(query_set, begin)| ComputePassTimestampWrites {
                query_set,
                beginning_of_pass_write_index: Some(begin),
                end_of_pass_write_index: Some(begin + 1),
            })
    }

    /// Resolves this frame's timestamps into the read-back buffer.
    pub fn end_frame(&mut self, encoder: &mut CommandEncoder) {
        let (Some(query_set), Some(resolve), Some(readback)) =
            (&self.query_set, &self.resolve, &self.readback)
        else {
            return;
        };
        if self.used == 0 || self.in_flight.is_some() {
            return;
        }
        encoder.resolve_query_set(query_set, 0..self.used, resolve, 0);
        encoder.copy_buffer_to_buffer(resolve, 0, readback, 0, self.used as u64 * 8);
        self.copied = true;
    }

    /// After the frame's commands are submitted: start mapping what `end_frame` copied.
    pub fn start_readback(&mut self) {
        let Some(readback) = &self.readback else {
            return;
        };
        if !self.copied || self.in_flight.is_some() {
            return;
        }
        let state = Arc::new(AtomicU8::new(PENDING));
        let flag = state.clone();
        readback
            .slice(..self.used as u64 * 8)
            .map_async(MapMode::Read, move |r| {
                flag.store(if r.is_ok() { MAPPED } else { FAILED }, Ordering::Release);
            });
        self.in_flight = Some((std::mem::take(&mut self.spans), self.frame, state));
        self.copied = false;
    }

    /// Collects a completed read-back into `last_ms`; returns whether new numbers arrived.
    pub fn collect(&mut self, device: &RenderDevice, wait: bool) -> bool {
        let Some(readback) = &self.readback else {
            return false;
        };
        let Some((spans, frame, state)) = &self.in_flight else {
            return false;
        };
        let poll = if wait {
            PollType::wait_indefinitely()
        } else {
            PollType::Poll
        };
        let _ = device.poll(poll);
        match state.load(Ordering::Acquire) {
            PENDING => return false,
            FAILED => {
                self.in_flight = None;
                return false;
            }
            _ => {}
        }
        let mut ms = [0.0f64; STAGES];
        {
            let view = readback.slice(..spans.len() as u64 * 16).get_mapped_range();
            let ticks: &[u64] = bytemuck::cast_slice(&view);
            for (i, stage) in spans.iter().enumerate() {
                let dt = ticks[2 * i + 1].saturating_sub(ticks[2 * i]);
                ms[stage.index()] += dt as f64 * self.period_ns as f64 * 1e-6;
            }
        }
        readback.unmap();
        self.last_ms = ms;
        for (total, frame) in self.total_ms.iter_mut().zip(ms) {
            *total += frame;
        }
        self.timed_iterations += frame.iterations as u64;
        self.last_frame = *frame;
        self.in_flight = None;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stage_index_is_its_place_in_all() {
        for (i, stage) in Stage::ALL.iter().enumerate() {
            assert_eq!(stage.index(), i, "{stage:?}");
        }
    }
}
