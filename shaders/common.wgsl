// Shared structs and helpers of every bevy_rppm stage. Layouts mirror src/scene/mod.rs and
// src/iteration.rs byte for byte.
#define_import_path bevy_rppm::common

const PI: f32 = 3.141592653589793;

struct Triangle {
    position_a: vec3<f32>,
    material: u32,
    position_b: vec3<f32>,
    pad_b: u32,
    position_c: vec3<f32>,
    pad_c: u32,
    normal_a: vec3<f32>,
    pad_na: u32,
    normal_b: vec3<f32>,
    pad_nb: u32,
    normal_c: vec3<f32>,
    pad_nc: u32,
}

struct Material {
    base_color: vec4<f32>,
    emissive: vec4<f32>,
    metallic: f32,
    perceptual_roughness: f32,
    reflectance: f32,
    specular_transmission: f32,
    ior: f32,
    flags: u32,
    pad_a: u32,
    pad_b: u32,
}

const LIGHT_POINT: u32 = 0u;
const LIGHT_SPOT: u32 = 1u;
const LIGHT_DIRECTIONAL: u32 = 2u;

struct Light {
    kind: u32,
    shadow_layer: u32,
    cos_inner: f32,
    cos_outer: f32,
    position: vec4<f32>,
    direction: vec4<f32>,
    // rgb: W/sr (point, spot) or W/m² (directional); w: power for photon splitting.
    radiance: vec4<f32>,
}

struct Emitter {
    triangle: u32,
    area: f32,
    power: f32,
    cdf: f32,
}

// One view a shadow map is rendered from: a cube face of a point, spot or area-light sample,
// or a directional light's orthographic map.
struct ShadowView {
    clip_from_world: mat4x4<f32>,
    // xyz: eye (perspective) or direction light travels (orthographic); w: 1 perspective, 0 ortho.
    origin: vec4<f32>,
    // Unit axis the view looks along.
    axis: vec4<f32>,
    near: f32,
    far: f32,
    // World-space size of one texel at unit distance (perspective) or absolute (ortho).
    texel: f32,
    pad: f32,
}

// Per-iteration constants (uniform, one 256-byte slot per iteration of a frame).
struct IterationParams {
    clip_from_world: mat4x4<f32>,
    camera_position: vec4<f32>,
    // Area-light sample for this iteration: position (w = 1 if any), normal, radiance / pdf.
    area_position: vec4<f32>,
    area_normal: vec4<f32>,
    area_weight: vec4<f32>,
    size: vec2<u32>,
    iteration: u32,
    light_count: u32,
    // World-space pixel size at unit view depth (perspective) or absolute (ortho).
    pixel_spread: f32,
    orthographic: u32,
    // First shadow view of this iteration's area-light cube, and its first texture layer.
    area_view: u32,
    area_layer: u32,
    shadow_resolution: u32,
    exposure: f32,
    tonemap: u32,
    pad: u32,
}

fn triangle_position(t: Triangle, corner: u32) -> vec3<f32> {
    switch corner {
        case 0u: { return t.position_a; }
        case 1u: { return t.position_b; }
        default: { return t.position_c; }
    }
}

fn triangle_normal(t: Triangle, corner: u32) -> vec3<f32> {
    switch corner {
        case 0u: { return t.normal_a; }
        case 1u: { return t.normal_b; }
        default: { return t.normal_c; }
    }
}

fn luminance(c: vec3<f32>) -> f32 {
    return dot(c, vec3<f32>(0.2126, 0.7152, 0.0722));
}
