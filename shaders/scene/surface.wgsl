// What surface a G-buffer texel sees, as a pixel's history keeps it (accumulate.wgsl,
// reproject.wgsl), and whether another point is of the same surface: an edge's subpixels
// (resolve.wgsl) and a pixel's shading points (eye_paths.wgsl) are told apart by it too.
#define_import_path bevy_rppm::surface

#import bevy_rppm::common::{IterationParams, MOVED_TRIANGLE}
#import bevy_rppm::camera::toward_eye
#import bevy_rppm::scene::{gbuffer_triangle, front_emitting, triangles}

// Bits of a surface's marker byte (0: no surface): a surface, on a triangle that moved in
// this frame's placement, emitting (its emissive factor, a texture only scales it, seen from
// the front); and, of a kept one, that the pixel's history holds samples of another surface
// too (an edge its jitter crossed: empty pixels keep this bit alone).
const KEPT: u32 = 0x80u;
const KEPT_MOVING: u32 = 1u;
const KEPT_EMITTING: u32 = 2u;
const KEPT_MIXED: u32 = 4u;
// Bits 3–6: a tag of its material, so that surfaces a footprint apart are told apart too (a
// thin black square on a white floor).
const TAG_SHIFT: u32 = 3u;
const TAG_BITS: u32 = 0x78u;

// The marker byte of the surface at a G-buffer texel, from one read of its triangle.
fn surface_marks(position: vec4<f32>) -> u32 {
    if position.w == 0.0 {
        return 0u;
    }
    let material = triangles[gbuffer_triangle(position.w)].material;
    let emitting = front_emitting(material, position.w);
    // The index's low four bits: materials fewer than 16 apart differ.
    let tag = (material & (TAG_BITS >> TAG_SHIFT)) << TAG_SHIFT;
    return KEPT | tag | select(0u, KEPT_MOVING, (material & MOVED_TRIANGLE) != 0u) | select(0u, KEPT_EMITTING, emitting);
}

// Whether a marker byte is an emitting surface's.
fn emitting(marks: u32) -> bool {
    return (marks & KEPT_EMITTING) != 0u;
}

// A G-buffer texel as kept in `surface`: position, and the normal packed with its marker byte.
fn packed_surface(position: vec4<f32>, normal: vec3<f32>, marks: u32) -> vec4<f32> {
    let packed = (pack4x8snorm(vec4<f32>(normal, 0.0)) & 0x00ffffffu) | (marks << 24u);
    return vec4<f32>(position.xyz, bitcast<f32>(select(marks << 24u, packed, position.w != 0.0)));
}

// Whether a kept history holds samples of more than one surface.
fn mixed_surface(kept: vec4<f32>) -> bool {
    return ((bitcast<u32>(kept.w) >> 24u) & KEPT_MIXED) != 0u;
}

// Whether a kept surface was on a moving object.
fn moved_surface(kept: vec4<f32>) -> bool {
    return ((bitcast<u32>(kept.w) >> 24u) & KEPT_MOVING) != 0u;
}

// Whether a kept surface is the one this pixel sees now: both empty, or a point on the same
// plane, within three footprints across the view (the jitter moves it by up to one and a
// half; more along a surface seen at a grazing angle), with a normal within ~25°, of the
// same material tag, emitting if and only if it does (an emitter's rim on its wall is no
// history of the wall): a moving object's pixels start again.
fn same_surface(params: IterationParams, kept: vec4<f32>, position: vec4<f32>, normal: vec4<f32>, marks: u32) -> bool {
    let packed = bitcast<u32>(kept.w);
    let had = ((packed >> 24u) & KEPT) != 0u;
    if !had || position.w == 0.0 {
        return had == (position.w != 0.0);
    }
    let kept_normal = unpack4x8snorm(packed).xyz;
    let d = position.xyz - kept.xyz;
    let slack = 1e-4 * length(position.xyz);
    let facing = abs(dot(normal.xyz, toward_eye(params, position.xyz)));
    let across = 3.0 * normal.w / max(facing, 0.2);
    let near = length(d) <= across + slack && abs(dot(d, normal.xyz)) <= normal.w + slack;
    let tagged = ((packed >> 24u) & TAG_BITS) == (marks & TAG_BITS);
    return near && tagged && dot(kept_normal, normal.xyz) > 0.9 && emitting(packed >> 24u) == emitting(marks);
}

// Neighbour k (0..9, the pixel itself at 4) of `pixel` in its 3×3 block, inside an image of
// `size`.
fn neighbour(size: vec2<u32>, pixel: vec2<u32>, k: i32) -> vec2<i32> {
    let at = vec2<i32>(pixel) + vec2<i32>(k % 3 - 1, k / 3 - 1);
    return clamp(at, vec2<i32>(0), vec2<i32>(size) - 1);
}
