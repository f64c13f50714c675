// The progressive estimate: this iteration's local illumination plus its splatted photons
// (directly on the G-buffer, and through importons), averaged into the radiance of all
// iterations since the last reset (w: the pixel's count), or with HISTORY of the pixel's
// history kept through motion.
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
#ifdef HISTORY
// Per pixel, in three blocks of one vec4 a pixel: the surface it saw, the running mean of its
// direct light (local illumination; w its count) and the second moment of its indirect light's
// luminance (x). `radiance` holds their total: direct plus indirect (w the indirect count).
@group(1) @binding(7) var<storage, read_write> history: array<vec4<f32>>;
// Last frame's estimate and history, for reprojection.
@group(1) @binding(8) var<storage, read> previous_radiance: array<vec4<f32>>;
@group(1) @binding(9) var<storage, read> previous_history: array<vec4<f32>>;

// HistoryFlags (src/view/params.rs).
const REPROJECT: u32 = 1u;
const CHECK_SURFACE: u32 = 2u;
const CHECK_LIGHT: u32 = 4u;

// A G-buffer texel as kept in `surface`: position, and the normal packed with a marker byte
// (0: no surface).
fn packed_surface(position: vec4<f32>, normal: vec3<f32>) -> vec4<f32> {
    let packed = select(0u, pack4x8snorm(vec4<f32>(normal, 1.0)), position.w != 0.0);
    return vec4<f32>(position.xyz, bitcast<f32>(packed));
}

// Whether a kept surface is the one this pixel sees now: both empty, or a point within three
// footprints (the jitter moves it by up to one and a half) on the same plane, with a normal
// within ~25°: a moving object's pixels start again.
fn same_surface(kept: vec4<f32>, position: vec4<f32>, normal: vec4<f32>) -> bool {
    let packed = bitcast<u32>(kept.w);
    let had = (packed >> 24u) != 0u;
    if !had || position.w == 0.0 {
        return had == (position.w != 0.0);
    }
    let kept_normal = unpack4x8snorm(packed).xyz;
    let d = position.xyz - kept.xyz;
    let slack = 1e-4 * length(position.xyz);
    let near = length(d) <= 3.0 * normal.w + slack && abs(dot(d, normal.xyz)) <= normal.w + slack;
    return near && dot(kept_normal, normal.xyz) > 0.9;
}

fn luminance(c: vec3<f32>) -> f32 {
    return dot(c, vec3<f32>(0.2126, 0.7152, 0.0722));
}

// Where this pixel's surface was in last frame's image, or -1 outside it.
fn reprojected(position: vec4<f32>) -> i32 {
    if position.w == 0.0 {
        return -1;
    }
    let clip = params.previous_clip_from_world * vec4<f32>(position.xyz, 1.0);
    if clip.w <= 0.0 {
        return -1;
    }
    let uv = vec2<f32>(0.5, -0.5) * clip.xy / clip.w + 0.5;
    let pixel = vec2<i32>(floor(uv * vec2<f32>(params.size)));
    if any(pixel < vec2<i32>(0)) || any(pixel >= vec2<i32>(params.size)) {
        return -1;
    }
    return pixel.y * i32(params.size.x) + pixel.x;
}
#endif

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
    var kept = select(radiance[index], vec4<f32>(0.0), params.iteration == 0u);
#ifdef HISTORY
    let pixels = params.size.x * params.size.y;
    let position = textureLoad(gbuffer_position, vec2<i32>(id.xy), 0);
    let normal = textureLoad(gbuffer_normal, vec2<i32>(id.xy), 0);
    var kept_direct = select(history[pixels + index], vec4<f32>(0.0), params.iteration == 0u);
    var moment = history[2u * pixels + index].x;
    if (params.history_flags & CHECK_SURFACE) != 0u && params.iteration != 0u {
        var kept_surface = history[index];
        if (params.history_flags & REPROJECT) != 0u {
            let reprojection = reprojected(position);
            let source = u32(max(reprojection, 0));
            let found = reprojection >= 0;
            kept = select(vec4<f32>(0.0), previous_radiance[source], found);
            kept_surface = select(vec4<f32>(0.0), previous_history[source], found);
            kept_direct = select(vec4<f32>(0.0), previous_history[pixels + source], found);
            moment = select(0.0, previous_history[2u * pixels + source].x, found);
        }
        if !same_surface(kept_surface, position, normal) {
            kept = vec4<f32>(0.0);
            kept_direct = vec4<f32>(0.0);
        }
    }
    // Direct light (this iteration's local sample) and indirect light (its splats) are kept
    // apart. While a change in the scene settles, direct light, traced anew each iteration
    // with little noise, keeps no history, so moving shadows follow at once; indirect light
    // keeps the window, and starts again where it departs from its history by more than 4 σ
    // of its own iterations (and 5 %): a change, not noise.
    let direct_sample = samples[index].rgb;
    let indirect_sample = sample - direct_sample;
    var indirect = kept.rgb - kept_direct.rgb;
    if (params.history_flags & CHECK_LIGHT) != 0u && kept.w >= 2.0 {
        let mean = luminance(indirect);
        let sigma = sqrt(max(moment - mean * mean, 0.0));
        let departure = abs(luminance(indirect_sample) - mean);
        kept.w = select(kept.w, 0.0, departure > 4.0 * sigma + 0.05 * mean + 1e-6);
    }
    kept.w = min(kept.w, f32(params.history_cap));
    kept_direct.w = select(0.0, kept_direct.w, params.history_cap == 0xffffffffu);
    let l = luminance(indirect_sample);
    moment = select(moment + (l * l - moment) / (kept.w + 1.0), l * l, kept.w == 0.0);
    indirect = select(indirect, vec3<f32>(0.0), kept.w == 0.0);
    indirect += (indirect_sample - indirect) / (kept.w + 1.0);
    var direct = select(kept_direct.rgb, vec3<f32>(0.0), kept_direct.w == 0.0);
    direct += (direct_sample - direct) / (kept_direct.w + 1.0);
    history[index] = packed_surface(position, normal.xyz);
    history[pixels + index] = vec4<f32>(direct, kept_direct.w + 1.0);
    history[2u * pixels + index] = vec4<f32>(moment, 0.0, 0.0, 0.0);
    radiance[index] = vec4<f32>(direct + indirect, kept.w + 1.0);
#else
    let previous = select(kept.rgb, vec3<f32>(0.0), params.iteration == 0u);
    let n = f32(params.iteration);
    radiance[index] = vec4<f32>(previous + (sample - previous) / (n + 1.0), n + 1.0);
#endif
}
