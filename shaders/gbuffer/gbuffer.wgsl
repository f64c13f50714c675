// Camera G-buffer: world position, shading normal (normal maps applied), material and pixel
// footprint, rasterised with this iteration's sub-pixel jitter (baked into clip_from_world);
// alpha cut-outs are discarded.
#import bevy_rppm::common::{IterationParams, triangle_position, triangle_normal}
#import bevy_rppm::scene::{triangle_at, barycentrics, opaque_at, normal_at}

@group(1) @binding(0) var<uniform> params: IterationParams;

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) @interpolate(flat) triangle: u32,
}

@vertex
fn vertex(@builtin(vertex_index) vertex: u32) -> VertexOut {
    let t = triangle_at(vertex / 3u);
    let corner = vertex % 3u;
    var out: VertexOut;
    out.world = triangle_position(t, corner);
    out.normal = triangle_normal(t, corner);
    out.triangle = vertex / 3u;
    out.clip = params.clip_from_world * vec4<f32>(out.world, 1.0);
    return out;
}

struct GBuffer {
    // xyz: world position; w: ±(triangle + 1), negative when the back face is seen, 0 = miss.
    @location(0) position: vec4<f32>,
    // xyz: shading normal facing the camera; w: footprint, the world size of this pixel.
    @location(1) normal: vec4<f32>,
}

@fragment
fn fragment(in: VertexOut, @builtin(front_facing) front: bool) -> GBuffer {
    let b = barycentrics(triangle_at(in.triangle), in.world);
    if !opaque_at(in.triangle, b) {
        discard;
    }
    var footprint = params.pixel_spread;
    if params.orthographic == 0u {
        footprint *= distance(in.world, params.camera_position.xyz);
    }
    // The normal map at its finest level (normal_at); the jitter averages its texels.
    var n = normal_at(in.triangle, b, normalize(in.normal));
    if !front {
        n = -n;
    }
    let tag = f32(in.triangle + 1u);
    var out: GBuffer;
    out.position = vec4<f32>(in.world, select(-tag, tag, front));
    out.normal = vec4<f32>(n, footprint);
    return out;
}
