// Writes the radiance estimate into the Bevy view, scaled by the camera's exposure. Views
// without HDR get a simple tonemap here, as Bevy tonemaps them inside its own shaders.
#import bevy_rppm::common::{IterationParams, luminance}

@group(0) @binding(0) var<uniform> params: IterationParams;
@group(0) @binding(1) var<storage, read> radiance: array<vec4<f32>>;

@vertex
fn vertex(@builtin(vertex_index) vertex: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32(vertex >> 1u), f32(vertex & 1u)) * 2.0;
    return vec4<f32>(uv * vec2<f32>(2.0, -2.0) + vec2<f32>(-1.0, 1.0), 0.0, 1.0);
}

@fragment
fn fragment(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = min(vec2<u32>(position.xy), params.size - vec2<u32>(1u));
    var c = radiance[pixel.y * params.size.x + pixel.x].rgb * params.exposure;
    if params.tonemap != 0u {
        c = c / (1.0 + luminance(c));
    }
    return vec4<f32>(c, 1.0);
}
