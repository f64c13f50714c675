// The progressive estimate: this iteration's local illumination plus its splatted photons
// (directly on the G-buffer, and through importons),
// averaged into the radiance of all iterations since the last reset.
#import bevy_rppm::common::{IterationParams, subsample_representative}
#ifdef SUBSAMPLED
#import bevy_rppm::scene::gbuffer_material
#import bevy_rppm::bsdf::bsdf_eval
#endif

@group(1) @binding(0) var<uniform> params: IterationParams;
@group(1) @binding(1) var<storage, read> samples: array<vec4<f32>>;
@group(1) @binding(2) var splats: texture_2d<f32>;
@group(1) @binding(3) var<storage, read_write> radiance: array<vec4<f32>>;
// Photons gathered by this iteration's importons, per pixel.
@group(1) @binding(4) var<storage, read> importon_radiance: array<vec4<f32>>;
@group(1) @binding(5) var gbuffer_position: texture_2d<f32>;
@group(1) @binding(6) var gbuffer_normal: texture_2d<f32>;

#ifdef SUBSAMPLED
// Joint-bilateral upsampling of the subsampled incident light: the four texels around the
// pixel, weighted bilinearly and by how well their representative pixel's surface matches
// this one's (normal agreement, distance from this pixel's tangent plane in footprints).
fn upsampled_light(pixel: vec2<u32>, x: vec3<f32>, n: vec3<f32>, footprint: f32) -> vec3<f32> {
    let s = f32(params.indirect_subsampling);
    let texels = vec2<i32>(textureDimensions(splats));
    let c = (vec2<f32>(pixel) + 0.5) / s - 0.5;
    let base = vec2<i32>(floor(c));
    let f = c - floor(c);
    var sum = vec3<f32>(0.0);
    var total = 0.0;
    var nearest = vec3<f32>(0.0);
    var nearest_distance = 1e30;
    for (var k = 0; k < 4; k += 1) {
        let offset = vec2<i32>(k & 1, k >> 1u);
        let texel = clamp(base + offset, vec2<i32>(0), texels - 1);
        let rep = subsample_representative(params, vec2<u32>(texel));
        let q = textureLoad(gbuffer_position, rep, 0);
        let light = textureLoad(splats, texel, 0).rgb;
        if q.w == 0.0 {
            continue;
        }
        let qn = textureLoad(gbuffer_normal, rep, 0).xyz;
        let plane = abs(dot(q.xyz - x, n)) / max(footprint * s, 1e-12);
        let bilinear = mix(1.0 - f.x, f.x, f32(offset.x)) * mix(1.0 - f.y, f.y, f32(offset.y));
        let w = bilinear * pow(max(dot(n, qn), 0.0), 8.0) / (1.0 + plane * plane);
        sum += w * light;
        total += w;
        let d = distance(q.xyz, x);
        if d < nearest_distance {
            nearest_distance = d;
            nearest = light;
        }
    }
    return select(nearest, sum / total, total > 1e-4);
}
#endif

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= params.size) {
        return;
    }
    let index = id.y * params.size.x + id.x;
    var sample = samples[index].rgb;
#ifdef SUBSAMPLED
    let gp = textureLoad(gbuffer_position, vec2<i32>(id.xy), 0);
    if gp.w != 0.0 {
        let gn = textureLoad(gbuffer_normal, vec2<i32>(id.xy), 0);
        let m = gbuffer_material(gp, gn.w);
        let wo = normalize(params.camera_position.xyz - gp.xyz);
        let light = upsampled_light(id.xy, gp.xyz, gn.xyz, gn.w);
        sample += bsdf_eval(m, gn.xyz, wo, gn.xyz) * light;
    }
#else
    sample += textureLoad(splats, vec2<i32>(id.xy), 0).rgb;
#endif
#ifdef IMPORTONS
    sample += importon_radiance[index].rgb;
#endif
    let previous = select(radiance[index].rgb, vec3<f32>(0.0), params.iteration == 0u);
    radiance[index] = vec4<f32>(previous + (sample - previous) / f32(params.iteration + 1u), 1.0);
}
