//! The choices among ways of running: what the image does to the view, debug images, what
//! motion does to the estimate, what traces rays.

use bevy::prelude::*;

/// What the photon-mapped image does to the view.
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[reflect(Default, Clone, PartialEq, Hash)]
pub enum RppmMode {
    /// The progressive estimate (local illumination plus photon-mapped light) replaces the view.
    #[default]
    Full,
    /// Bevy's own lighting (its direct light, shadows, emission) plus our light from every other
    /// path (photon-mapped indirect light, and what mirrors and glass show), added in HDR before
    /// Bevy's tonemapping with the view's exposure. Needs an HDR camera (`Hdr`).
    Indirect,
}

/// Images for checking the pipeline by eye; `None` renders the estimate. The others need the
/// crate's `debug` feature (without it they are clamped to `None` with a warning).
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[reflect(Default, Clone, PartialEq, Hash)]
pub enum RppmDebugView {
    #[default]
    None,
    /// Shading normals (n·0.5 + 0.5) of the rasterised camera G-buffer.
    GBufferNormals,
    /// Shading normals of primary rays traced through the deep cubemap, with the G-buffer's
    /// jitter: it should match `GBufferNormals`.
    CubemapNormals,
    /// Direct light from photons (stored at their first hit, not bounced) instead of shadow
    /// maps: it should match the estimate with no photons (`PhotonCount::Fixed(0)`), which checks
    /// photon flux against the local stage.
    DirectPhotons,
}

/// What a change in the scene or a camera move does to the progressive estimate. A change of
/// the settings or of the target's size, and an object or light added or removed, always
/// start again.
#[derive(Reflect, Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[reflect(Default, Clone, PartialEq, Hash)]
pub enum RppmHistory {
    /// Any change starts the estimate again: RPPM's behaviour, for stills (the `rppm` CLI and
    /// the accuracy tests use it). Holds no history.
    Reset,
    /// Keep the estimate through motion (default, `iterations: 8`: a game, where something always
    /// moves, shows converging light instead of one iteration's noise a frame; see the README's
    /// measurements: 4× lower error than `Reset` on the moving pool, 2–14× under most orbits,
    /// a moving light and a walking character). After any change each pixel keeps at most
    /// `iterations` iterations of history (an exponential window) for `iterations` more iterations.
    /// After a camera move the history is reprojected to where each pixel's surface was, and
    /// dropped where the pixel sees another surface (disocclusion); the frame keeps one surface a
    /// pixel and shows an edge's pixels from 8 rays through them, each taking the light of the
    /// pixel that sees what it met. A move keeps the light on a texture and shows each pixel's
    /// footprint's albedo now, and keeps 3 samples of direct light where it is exact (up to 8
    /// point, spot and directional lights alone). After a change in the scene, indirect light is
    /// clamped to mean ± σ of the neighbouring pixels' means since the change, so a caustic that
    /// moved does not linger, and direct light starts again. A still scene converges as with
    /// `Reset`. The window counts iterations, not frames: with several a frame
    /// ([`IterationsPerFrame`]) it spans fewer frames. Holds 64 bytes a pixel (16 more where glass
    /// or mirrors show what is past them, 16 where textures vary albedo), and from the first change
    /// on 16 more and last frame's history, for reprojection. Range of `iterations` 1..=1024.
    Reuse { iterations: u32 },
}

impl Default for RppmHistory {
    fn default() -> Self {
        Self::Reuse { iterations: 8 }
    }
}

impl RppmHistory {
    /// The history window of `Reuse`.
    pub fn window(self) -> Option<u32> {
        match self {
            Self::Reset => None,
            Self::Reuse { iterations } => Some(iterations),
        }
    }
}

/// What traces the rays of photons, camera paths and shadows. Both are exact: they find the
/// same hits (the DIRT bench checks every ray against brute force), so the choice is speed.
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[reflect(Default, Clone, PartialEq, Hash)]
pub enum RppmTracer {
    /// What measured fastest (default): today the BVH, on a software adapter (llvmpipe) and
    /// on GPUs alike. On an H200 it ran 1.8–3.5× the iterations of the deep cubemap in equal
    /// time on seven suite scenes (a faster iteration on all of them) and 15× on a still scene
    /// of 10⁶ triangles, whose cubemap build alone took 59 ms an iteration (README). Where the hierarchy is too big for the device's textures,
    /// the deep cubemap.
    #[default]
    Auto,
    /// The camera-centred deep cubemap, rebuilt by rasterisation every iteration (DIRT, as the
    /// paper).
    DeepCubemap,
    /// A bounding-volume hierarchy built on the CPU when the scene's meshes come or go
    /// (binned SAH; about 0.26 s at 10⁶ triangles on two cores) and refitted where they move
    /// or deform (the moved triangles placed again, their boxes made again), walked on the
    /// GPU. On llvmpipe it traces 2–7× more rays a second than the deep cubemap (README).
    Bvh,
}

impl RppmTracer {
    /// Whether rays go through the BVH (where it fits the device).
    pub fn uses_bvh(self) -> bool {
        match self {
            Self::Auto | Self::Bvh => true,
            Self::DeepCubemap => false,
        }
    }
}
