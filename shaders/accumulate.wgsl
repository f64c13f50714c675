// The progressive estimate: this iteration's local illumination plus its splatted photons
// (directly on the G-buffer, and through importons),
// averaged into the radiance of all iterations since the last reset.
#import bevy_rppm::common::IterationParams

@group(0) @binding(0) var<uniform> params: IterationParams;
@group(0) @binding(1) var<storage, read> samples: array<vec4<f32>>;
@group(0) @binding(2) var splats: texture_2d<f32>;
@group(0) @binding(3) var<storage, read_write> radiance: array<vec4<f32>>;
// Photons gathered by this iteration's importons, per pixel.
@group(0) @binding(4) var<storage, read> importon_radiance: array<vec4<f32>>;

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= params.size) {
        return;
    }
    let index = id.y * params.size.x + id.x;
    var sample = samples[index].rgb + textureLoad(splats, vec2<i32>(id.xy), 0).rgb;
#ifdef IMPORTONS
    sample += importon_radiance[index].rgb;
#endif
    let previous = select(radiance[index].rgb, vec3<f32>(0.0), params.iteration == 0u);
    radiance[index] = vec4<f32>(previous + (sample - previous) / f32(params.iteration + 1u), 1.0);
}
