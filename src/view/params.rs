//! The per-iteration constants every stage reads (`IterationParams` in common.wgsl): the
//! camera with this iteration's sub-pixel jitter, the area-light sample, the settings.

use bevy::prelude::*;
use bevy::render::camera::ExtractedCamera;
use bevy::render::render_resource::{Buffer, BufferBinding, BufferSize};
use bevy::render::view::ExtractedView;
use bytemuck::{Pod, Zeroable};

use crate::ppm::{halton, pcg, unit_random};
use crate::scene::{GpuTriangle, LightKind, SceneData};

/// Byte stride between per-iteration slots of the params buffer (dynamic-offset alignment).
pub const PARAMS_STRIDE: u64 = 512;

/// Per-iteration constants (`IterationParams` in common.wgsl, 416 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct IterationParams {
    pub clip_from_world: [[f32; 4]; 4],
    pub world_from_clip: [[f32; 4]; 4],
    pub camera_position: [f32; 4],
    pub area_position: [f32; 4],
    pub area_normal: [f32; 4],
    pub area_weight: [f32; 4],
    pub size: [u32; 2],
    pub iteration: u32,
    pub light_count: u32,
    pub pixel_spread: f32,
    pub orthographic: u32,
    pub area_view: u32,
    pub area_layer: u32,
    pub shadow_resolution: u32,
    pub exposure: f32,
    pub tonemap: u32,
    pub photons: u32,
    pub max_photon_depth: u32,
    pub photon_capacity: u32,
    pub source_count: u32,
    pub splat_radius: f32,
    pub max_eye_depth: u32,
    pub splat_russian_roulette: u32,
    pub direct_photons: u32,
    pub indirect_only: u32,
    pub scene_sphere: [f32; 4],
    pub kernel_flattening: f32,
    pub indirect_subsampling: u32,
    /// Iterations of history a pixel keeps (`u32::MAX`: all, no change to settle).
    pub history_cap: u32,
    /// `HistoryFlags` (`accumulate::clock`) of this iteration.
    pub history_flags: u32,
    /// Last frame's (unjittered) clip_from_world, for reprojecting history.
    pub previous_clip_from_world: [[f32; 4]; 4],
    /// The sky's radiance (linear RGB), w 1 when there is one (`ScatterPaths::SKY`).
    pub sky: [f32; 4],
    /// Index of the iteration's random numbers: `iteration`, shifted by `PhotonMapping::seed`.
    pub sequence: u32,
    /// Invocations that trace the photons, each taking the next when its photon ends.
    pub photon_lanes: u32,
    /// Power of all emissive triangles together (luminance-weighted W): the emitters'
    /// densities for multiple importance sampling at camera paths' rough vertices.
    pub emitter_power: f32,
    /// 1 when photons leave a sun or the sky: local illumination counts how far the camera
    /// sees, which their emission follows (photons/trace.wgsl).
    pub seen_region: u32,
    /// This iteration's sub-pixel jitter (pixels, x right and y down): its samples lie this
    /// far before the pixels' centres in the unjittered image.
    pub jitter: [f32; 2],
    /// Where local illumination shades each pixel past its G-buffer sample, in pixels (0:
    /// there): a frame whose camera moved rasterizes every iteration at one jitter, so that
    /// each pixel's samples are of one surface, and moves its shading point over that surface
    /// instead (the jitter sequence's points where they meet it).
    pub shading_jitter: [f32; 2],
    /// The share of the resolved edges in what the frame shows
    /// (`resolve_share` in src/accumulate/resolve.rs; 0: the estimate as it is).
    pub resolve_share: f32,
    /// 1 on the first iteration of a Knaus–Zwicker radius sequence after a restart or a
    /// camera move: the pixels' kernel statistics (`shaders/photons/map.wgsl`) start again (a
    /// scene change under `Reuse` keeps them within `history_cap`).
    pub radius_restart: u32,
    /// The share of the gather radius caustic photons are gathered over
    /// (`InitialRadius::caustic_scale`; 1: all photons over the whole radius).
    pub caustic_scale: f32,
    /// This iteration's weight in each pixel's running mean, in (0, 1]: its photons over the
    /// count its gather radius is sized for. While `Auto` probes (16 384 photons and up, the
    /// radius for its `max`) an iteration is that much noisier, and a mean that weighed it
    /// as one of the settled count's let a few probing iterations hold most of the variance.
    pub photon_weight: f32,
    /// Where last frame's camera was (w 1), or, orthographic, the direction toward it (w 0).
    pub previous_eye: [f32; 4],
}

/// Bytes of how far the camera sees (`seen` in importons/eye_paths.wgsl): visible pixels
/// counted in 16 distance bins.
pub const SEEN_REGION_BYTES: u64 = 64;

/// The first slot of a params buffer, as group 1 binds it.
pub fn params_binding(params: &Buffer) -> BufferBinding<'_> {
    BufferBinding {
        buffer: params,
        offset: 0,
        size: BufferSize::new(std::mem::size_of::<IterationParams>() as u64),
    }
}

/// A point on the emissive surfaces chosen by power, with radiance divided by its area pdf.
pub fn area_sample(data: &SceneData, sequence: u32) -> Option<(Vec3, Vec3, Vec3)> {
    let mut seed = pcg(sequence ^ 0x9e37_79b9);
    let u = unit_random(&mut seed);
    let index = data
        .emitters
        .partition_point(|e| e.cdf < u)
        .min(data.emitters.len().checked_sub(1)?);
    let emitter = data.emitters[index];
    let previous = if index == 0 {
        0.0
    } else {
        data.emitters[index - 1].cdf
    };
    let probability = (emitter.cdf - previous).max(1e-12);
    let triangle: GpuTriangle = data.triangle(emitter.triangle as usize)?;
    let [a, b, c] = triangle.positions();
    let (r1, r2) = (unit_random(&mut seed).sqrt(), unit_random(&mut seed));
    let [p, q, r] = crate::scene::parts::corners(emitter.part);
    let w = p + (q - p) * (r1 * (1.0 - r2)) + (r - p) * (r1 * r2);
    let point = a + (b - a) * w.x + (c - a) * w.y;
    let normal = (b - a).cross(c - a).normalize();
    let emissive = Vec4::from(data.materials[triangle.material as usize].emissive).truncate();
    let weight = emissive * (emitter.area / probability);
    Some((point, normal, weight))
}

/// The sub-pixel offset of Halton jitter `index` (pixels, each axis in -0.5..0.5).
pub fn halton_jitter(index: u32) -> Vec2 {
    Vec2::new(halton(index + 1, 2), halton(index + 1, 3)) - 0.5
}

/// The camera part of an iteration's constants: the view with the sub-pixel `jitter`
/// (pixels), the area-light sample of the iteration's random numbers (`seed`) and the
/// scene's bounds. The stages' fields (photons, shadow views,
/// settings) are the caller's to fill.
pub fn camera_params(
    view: &ExtractedView,
    camera: &ExtractedCamera,
    size: UVec2,
    data: &SceneData,
    iteration: u32,
    seed: u32,
    jitter: Vec2,
) -> IterationParams {
    // Seed 0 draws the numbers an iteration always drew.
    let sequence = iteration.wrapping_add(seed.wrapping_mul(0x9e37_79b9));
    let offset = Vec3::new(
        2.0 * jitter.x / size.x as f32,
        -2.0 * jitter.y / size.y as f32,
        0.0,
    );
    let view_from_world = view.world_from_view.to_matrix().inverse();
    let clip_from_world = Mat4::from_translation(offset) * view.clip_from_view * view_from_world;
    let orthographic = view.clip_from_view.w_axis.w == 1.0;
    let pixel_spread = 2.0 / (view.clip_from_view.y_axis.y * size.y as f32);
    let area = area_sample(data, sequence);
    let (area_position, area_normal, area_weight) = match area {
        Some((p, n, w)) => (p.extend(1.0), n.extend(0.0), w.extend(0.0)),
        None => (Vec4::ZERO, Vec4::ZERO, Vec4::ZERO),
    };
    IterationParams {
        clip_from_world: clip_from_world.to_cols_array_2d(),
        world_from_clip: clip_from_world.inverse().to_cols_array_2d(),
        camera_position: view.world_from_view.translation().extend(1.0).into(),
        area_position: area_position.into(),
        area_normal: area_normal.into(),
        area_weight: area_weight.into(),
        size: size.into(),
        iteration,
        sequence,
        light_count: data.lights.len() as u32,
        pixel_spread,
        orthographic: orthographic as u32,
        exposure: camera.exposure,
        tonemap: (!camera.hdr) as u32,
        max_eye_depth: 1,
        emitter_power: data.emitter_power(),
        seen_region: u32::from(
            data.sky[3] > 0.0
                || (data.lights.iter()).any(|l| l.kind == LightKind::Directional as u32),
        ),
        scene_sphere: {
            let (centre, radius) = data.bounding_sphere();
            centre.extend(radius.max(1e-6)).into()
        },
        kernel_flattening: 0.1,
        indirect_subsampling: 1,
        history_cap: u32::MAX,
        caustic_scale: 1.0,
        jitter: jitter.into(),
        sky: {
            let [r, g, b, power] = data.sky;
            [r, g, b, if power > 0.0 { 1.0 } else { 0.0 }]
        },
        ..default()
    }
}

/// Where the camera of a clip_from_world is (w 1), or, orthographic, the direction toward it
/// (w 0): the point (direction) that maps to clip x = y = w = 0, reversed z.
pub fn eye_of(clip_from_world: Mat4) -> Vec4 {
    let h = clip_from_world.inverse() * Vec4::Z;
    if h.w.abs() > f32::EPSILON * h.truncate().length() {
        (h.truncate() / h.w).extend(1.0)
    } else {
        h.truncate().normalize_or_zero().extend(0.0)
    }
}

/// The unjittered clip_from_world of a view: where last frame's history is looked up.
pub fn unjittered_clip_from_world(view: &ExtractedView) -> Mat4 {
    view.clip_from_view * view.world_from_view.to_matrix().inverse()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_eye_of_a_view_is_where_it_looks_from() {
        let world_from_view =
            Mat4::look_at_rh(Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO, Vec3::Y).inverse();
        let view_from_world = world_from_view.inverse();
        let perspective = Mat4::perspective_infinite_reverse_rh(0.8, 1.5, 0.1) * view_from_world;
        let eye = eye_of(perspective);
        assert_eq!(eye.w, 1.0);
        assert!(
            eye.truncate().distance(Vec3::new(1.0, 2.0, 3.0)) < 1e-4,
            "{eye}"
        );
        // Reversed z, as Bevy's orthographic projection: near maps to 1.
        let orthographic =
            Mat4::orthographic_rh(-2.0, 2.0, -1.0, 1.0, 100.0, 0.1) * view_from_world;
        let toward = eye_of(orthographic);
        assert_eq!(toward.w, 0.0);
        let expected = Vec3::new(1.0, 2.0, 3.0).normalize();
        assert!(toward.truncate().distance(expected) < 1e-4, "{toward}");
    }
}
