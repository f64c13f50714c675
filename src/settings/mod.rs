//! The camera components that turn photon mapping on and shape it, and the checks on their
//! values. A leaf: nothing else of the crate is used here.

use bevy::prelude::*;

mod counts;
mod modes;
mod radius;

pub use counts::{IterationsPerFrame, PhotonCount};
pub use modes::{RppmDebugView, RppmHistory, RppmMode, RppmTracer};
pub use radius::InitialRadius;

/// Rasterisation-based progressive photon mapping on a 3D camera.
///
/// Add it to a `Camera3d`. Every value is checked each time it changes: an out-of-range value
/// is **clamped** to its range with one warning (the image keeps rendering), never a panic.
/// Changing any value restarts the progressive estimate; what motion does is
/// [`history`](Self::history).
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Default, Clone, PartialEq)]
#[require(ViewEpoch)]
pub struct PhotonMapping {
    /// Whether the effect runs at all. Default `true`.
    pub enabled: bool,
    /// Full replacement or hybrid. Default [`RppmMode::Full`].
    pub mode: RppmMode,
    /// Photons emitted per iteration: a fixed count, or as many as the device affords.
    /// Default [`PhotonCount::Auto`] up to 262 144.
    pub photons_per_iteration: PhotonCount,
    /// Bounces a photon may take. Russian roulette by the albedo met ends most paths well
    /// before it; a low cap loses the light of long paths (8 left a bright open box 4 % dark
    /// in indirect light). Range 1..=64, default 16 (as camera paths and Mitsuba's path
    /// tracer).
    pub max_photon_depth: u32,
    /// Bounces an importon (camera path) may take through mirrors and glass; 1 means the
    /// camera G-buffer only. Past the third, Russian roulette ends paths (unbiased), so a high
    /// cap costs little. Range 1..=64, default 16 (as Mitsuba's path tracer).
    pub max_eye_depth: u32,
    /// Knaus–Zwicker radius reduction, r²ᵢ₊₁ = r²ᵢ (i+α)/(i+1). Range (0, 1], default 0.7.
    pub alpha: f32,
    /// Initial gather radius, in pixels of the camera view: default
    /// [`InitialRadius::PhotonShare`] of 6 pixels (6 in a 256² view of 262 144 photons an
    /// iteration, following the view's size and the photon count; caustic photons over no
    /// more than the 6: [`InitialRadius::caustic_scale`]). At most a quarter of the view's
    /// larger side.
    pub initial_radius: InitialRadius,
    /// Each pixel's photon kernels shrink below the global radius where their bias outweighs
    /// their noise: where the photons' density curves (a caustic's rim, seen directly or by
    /// a camera path through glass or a mirror), read from how a kernel's inner half's
    /// density departs from the whole disc's, down to a quarter of the global radius. `false`
    /// keeps the global radius everywhere and holds no per-pixel statistics (16 bytes a
    /// pixel, and as many again where camera paths go on); changing it restarts the
    /// estimate. Default `true`.
    pub adaptive_kernel: bool,
    /// Edge length in pixels of each face of the camera-centred deep cubemap.
    /// Range 16..=4096, default 256.
    pub cubemap_resolution: u32,
    /// Edge length in pixels of a cubemap tile, the unit that holds a set of depth-binned
    /// lists and one run of the photon map: 1, 2 or 4 (others are rounded to the nearest of
    /// these). Default 1.
    pub cubemap_tile_size: u32,
    /// Depth bins per cubemap tile. Range 1..=64, default 12.
    pub bins: u32,
    /// PPM iterations run per rendered frame: a fixed count, or as many as fit a GPU time
    /// budget. Default [`IterationsPerFrame::Fixed`]`(1)`.
    pub iterations_per_frame: IterationsPerFrame,
    /// Stop accumulating after this many iterations (the image then stays as it is until
    /// something changes). `None` (default) accumulates forever.
    pub max_iterations: Option<u32>,
    /// Russian roulette on splat fragments (p = 0.5, reweighted). Default `false`.
    pub splat_russian_roulette: bool,
    /// Edge length in texels of each face of a light's shadow cube (or a directional light's
    /// shadow map). Range 16..=8192, default 512.
    pub shadow_map_resolution: u32,
    /// Thickness of the photon gather kernel along the surface normal, as a fraction of its
    /// radius: ISPM's flattened photon volume, which stops light leaking across thin walls
    /// and into corners. Range 0.01..=1 (1: a sphere), default 0.1.
    pub kernel_flattening: f32,
    /// Photons are splatted onto every n-th pixel in x and y, and the gathered incident light
    /// is upsampled with a joint-bilateral filter on depth and normal (ISPM). The BSDF is
    /// applied per full-resolution pixel (exact for diffuse surfaces; glossy ones take their
    /// lobe at normal incidence). 1 (default, every pixel), 2 or 4.
    pub indirect_subsampling: u32,
    /// A debug image instead of the estimate. Default [`RppmDebugView::None`].
    pub debug_view: RppmDebugView,
    /// What a moved object, light or camera does to the estimate: keep it (temporal reuse)
    /// or start again. Default `RppmHistory::Reuse { iterations: 8 }`; [`RppmHistory::Reset`]
    /// for stills.
    pub history: RppmHistory,
    /// What traces rays. Default [`RppmTracer::Auto`] (today the BVH).
    pub tracer: RppmTracer,
    /// Profiling: every stage is submitted alone and waited for, and its CPU wall time is
    /// reported (`ViewStats::wall_ms_per_iteration`). Trustworthy where GPU timestamps are
    /// not (llvmpipe's overlap), and slow: it stalls the GPU between stages. Default false.
    pub profile_stages: bool,
    /// Which random numbers the estimate draws: renders of one scene with different seeds
    /// are independent (for averaging them, or a reference that shares no noise with a
    /// render). Any value; default 0.
    pub seed: u32,
}

/// Settings chosen from the speed/accuracy measurements of `rppm bench trade` (see the
/// README): each is the Pareto-best setting for its time budget on the Cornell scenes.
#[derive(Reflect, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RppmPreset {
    /// Interactive preview: 16 384 photons (fixed), subsampled splats, a 128² cubemap with 4 bins.
    Preview,
    /// The best image from about 5 to 20 seconds: 16 384 photons (fixed), subsampled splats.
    Balanced,
    /// Lowest error after a minute and more: 65 536 photons (fixed), full-resolution splats.
    Reference,
}

impl Default for PhotonMapping {
    fn default() -> Self {
        Self {
            enabled: true,
            mode: RppmMode::Full,
            photons_per_iteration: PhotonCount::default(),
            max_photon_depth: 16,
            max_eye_depth: 16,
            alpha: 0.7,
            initial_radius: InitialRadius::default(),
            adaptive_kernel: true,
            cubemap_resolution: 256,
            cubemap_tile_size: 1,
            bins: 12,
            iterations_per_frame: IterationsPerFrame::default(),
            max_iterations: None,
            splat_russian_roulette: false,
            shadow_map_resolution: 512,
            kernel_flattening: 0.1,
            indirect_subsampling: 1,
            debug_view: RppmDebugView::None,
            history: RppmHistory::default(),
            tracer: RppmTracer::default(),
            profile_stages: false,
            seed: 0,
        }
    }
}

impl From<RppmPreset> for PhotonMapping {
    fn from(preset: RppmPreset) -> Self {
        let base = PhotonMapping::default();
        match preset {
            // Fewer photons per iteration and more iterations win at every budget measured;
            // a coarser cubemap with fewer bins costs nothing in error at first and halves
            // memory.
            RppmPreset::Preview => PhotonMapping {
                photons_per_iteration: PhotonCount::Fixed(16_384),
                indirect_subsampling: 2,
                cubemap_resolution: 128,
                bins: 4,
                ..base
            },
            // The best setting from 5 s to 20 s on cornell_glass.
            RppmPreset::Balanced => PhotonMapping {
                photons_per_iteration: PhotonCount::Fixed(16_384),
                indirect_subsampling: 2,
                ..base
            },
            // No upsampling bias, and enough photons per iteration for minutes-long runs.
            RppmPreset::Reference => PhotonMapping {
                photons_per_iteration: PhotonCount::Fixed(65_536),
                ..base
            },
        }
    }
}

impl PhotonMapping {
    /// Returns a copy with every value inside its documented range, and one message per value
    /// that had to be clamped.
    pub fn validated(&self) -> (Self, Vec<String>) {
        let mut out = self.clone();
        let mut notes = Vec::new();
        match &mut out.photons_per_iteration {
            PhotonCount::Fixed(n) => clamp_u32(n, 0, 1 << 24, "photons_per_iteration", &mut notes),
            PhotonCount::Auto { max } => {
                clamp_u32(max, 1024, 1 << 24, "photons_per_iteration max", &mut notes);
            }
            PhotonCount::GpuMilliseconds { milliseconds, max } => {
                clamp_f32(
                    milliseconds,
                    0.1,
                    60_000.0,
                    "photon milliseconds",
                    &mut notes,
                );
                clamp_u32(max, 1024, 1 << 24, "photons_per_iteration max", &mut notes);
            }
        }
        clamp_u32(
            &mut out.max_photon_depth,
            1,
            64,
            "max_photon_depth",
            &mut notes,
        );
        clamp_u32(&mut out.max_eye_depth, 1, 64, "max_eye_depth", &mut notes);
        clamp_f32(&mut out.alpha, 1e-4, 1.0, "alpha", &mut notes);
        clamp_f32(
            out.initial_radius.value_mut(),
            0.25,
            256.0,
            "initial_radius",
            &mut notes,
        );
        clamp_u32(
            &mut out.cubemap_resolution,
            16,
            4096,
            "cubemap_resolution",
            &mut notes,
        );
        clamp_u32(&mut out.bins, 1, 64, "bins", &mut notes);
        round_to_power_of_two(&mut out.cubemap_tile_size, "cubemap_tile_size", &mut notes);
        round_to_power_of_two(
            &mut out.indirect_subsampling,
            "indirect_subsampling",
            &mut notes,
        );
        clamp_f32(
            &mut out.kernel_flattening,
            0.01,
            1.0,
            "kernel_flattening",
            &mut notes,
        );
        match &mut out.iterations_per_frame {
            IterationsPerFrame::Fixed(n) => clamp_u32(
                n,
                1,
                IterationsPerFrame::MOST,
                "iterations_per_frame",
                &mut notes,
            ),
            IterationsPerFrame::GpuMilliseconds { milliseconds, max } => {
                clamp_f32(
                    milliseconds,
                    0.1,
                    60_000.0,
                    "frame milliseconds",
                    &mut notes,
                );
                let most = IterationsPerFrame::MOST;
                clamp_u32(max, 1, most, "iterations_per_frame max", &mut notes);
            }
        }
        clamp_u32(
            &mut out.shadow_map_resolution,
            16,
            8192,
            "shadow_map_resolution",
            &mut notes,
        );
        if let RppmHistory::Reuse { iterations } = &mut out.history {
            clamp_u32(iterations, 1, 1024, "history iterations", &mut notes);
        }
        if !cfg!(feature = "debug") && out.debug_view != RppmDebugView::None {
            notes.push(format!(
                "PhotonMapping::debug_view = {:?} needs bevy_rppm's `debug` feature; using None",
                out.debug_view
            ));
            out.debug_view = RppmDebugView::None;
        }
        (out, notes)
    }
}

/// Rounds to 1, 2 or 4.
fn round_to_power_of_two(v: &mut u32, name: &str, notes: &mut Vec<String>) {
    let c = match *v {
        0..=1 => 1,
        2 | 3 => 2,
        _ => 4,
    };
    if c != *v {
        notes.push(format!(
            "PhotonMapping::{name} = {v} is not 1, 2 or 4; using {c}"
        ));
        *v = c;
    }
}

fn clamp_u32(v: &mut u32, lo: u32, hi: u32, name: &str, notes: &mut Vec<String>) {
    let c = (*v).clamp(lo, hi);
    if c != *v {
        notes.push(format!(
            "PhotonMapping::{name} = {v} is outside {lo}..={hi}; using {c}"
        ));
        *v = c;
    }
}

fn clamp_f32(v: &mut f32, lo: f32, hi: f32, name: &str, notes: &mut Vec<String>) {
    // NaN fails every comparison: map it to the low end rather than let it through.
    let c = if v.is_nan() { lo } else { v.clamp(lo, hi) };
    if c != *v || v.is_nan() {
        notes.push(format!(
            "PhotonMapping::{name} = {v} is outside {lo}..={hi}; using {c}"
        ));
        *v = c;
    }
}

/// Add to a `PhotonMapping` camera to receive its raw linear radiance (no exposure, no
/// tonemapping) in [`RppmRadiance`](crate::RppmRadiance) every frame. Each read-back waits for
/// the GPU, so add it only when you need the pixels.
#[derive(Component, Reflect, Clone, Copy, Debug, Default)]
#[reflect(Component, Default)]
pub struct RppmReadback;

/// Per-camera change counters. A new epoch (its settings or target size changed) restarts
/// the camera's progressive estimate; a new move (its transform or projection changed) does
/// too under [`RppmHistory::Reset`], and is reprojected under `Reuse`.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct ViewEpoch {
    pub epoch: u64,
    pub moves: u64,
    pub(crate) key: Option<ViewKey>,
    /// The target size the epoch was counted for (`None` before the first frame).
    pub(crate) target: Option<Option<UVec2>>,
}

/// What a camera's moves follow.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ViewKey {
    pub world_from_view: Mat4,
    pub clip_from_view: Mat4,
}

/// Jumps a camera's progressive estimate to this iteration, with the Knaus–Zwicker radius
/// shrunk as that many iterations would have (the running mean keeps what it holds), once per
/// new value: for checking the numbers far along the sequence without running it.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq)]
pub struct RppmFastForward(pub u32);

/// Clamps changed settings in place and warns once per change.
pub(crate) fn validate_settings(mut cameras: Query<&mut PhotonMapping, Changed<PhotonMapping>>) {
    for mut settings in &mut cameras {
        let (valid, notes) = settings.validated();
        if notes.is_empty() {
            continue;
        }
        for note in notes {
            warn!("bevy_rppm: {note}");
        }
        *settings = valid;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A game gets temporal reuse without asking; stills ask for `Reset`.
    #[test]
    fn the_default_keeps_the_estimate_through_motion() {
        let history = PhotonMapping::default().history;
        assert_eq!(history, RppmHistory::Reuse { iterations: 8 });
        assert_eq!(history.window(), Some(8));
        assert_eq!(RppmHistory::Reset.window(), None);
    }

    #[test]
    fn defaults_are_in_range() {
        let (v, notes) = PhotonMapping::default().validated();
        assert!(notes.is_empty(), "{notes:?}");
        assert_eq!(v, PhotonMapping::default());
    }

    #[test]
    fn extremes_are_clamped_with_a_message() {
        let s = PhotonMapping {
            alpha: f32::NAN,
            bins: 0,
            cubemap_resolution: 1 << 20,
            iterations_per_frame: IterationsPerFrame::GpuMilliseconds {
                milliseconds: f32::INFINITY,
                max: 0,
            },
            ..default()
        };
        let (v, notes) = s.validated();
        assert_eq!(notes.len(), 5, "{notes:?}");
        assert!(v.alpha > 0.0 && v.alpha <= 1.0);
        assert_eq!(v.bins, 1);
        assert_eq!(v.cubemap_resolution, 4096);
        assert_eq!(
            v.iterations_per_frame,
            IterationsPerFrame::GpuMilliseconds {
                milliseconds: 60_000.0,
                max: 1
            }
        );
    }

    #[test]
    fn auto_traces_through_the_bvh() {
        let auto = PhotonMapping::default().tracer;
        assert_eq!(auto, RppmTracer::Auto);
        assert!(auto.uses_bvh() && RppmTracer::Bvh.uses_bvh());
        assert!(!RppmTracer::DeepCubemap.uses_bvh());
    }
}
