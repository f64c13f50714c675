// Local illumination: emission seen by the camera plus direct light from every light with
// shadows from our shadow maps: this iteration's sample, before photons are added to it.
#import bevy_rppm::common::{Material, Light, IterationParams, LIGHT_SPOT, LIGHT_DIRECTIONAL}
#import bevy_rppm::bsdf::bsdf_eval
#import bevy_rppm::scene::{shadow_views, materials, lights}

@group(1) @binding(0) var<uniform> params: IterationParams;

@group(2) @binding(0) var gbuffer_position: texture_2d<f32>;
@group(2) @binding(1) var gbuffer_normal: texture_2d<f32>;
@group(2) @binding(2) var shadow_maps: texture_depth_2d_array;
@group(2) @binding(3) var<storage, read_write> samples: array<vec4<f32>>;

// Cube face whose frustum holds direction v (the order of src/shadows CUBE_FACES).
fn cube_face(v: vec3<f32>) -> u32 {
    let a = abs(v);
    if a.x >= a.y && a.x >= a.z {
        return select(1u, 0u, v.x > 0.0);
    }
    if a.y >= a.z {
        return select(3u, 2u, v.y > 0.0);
    }
    return select(5u, 4u, v.z > 0.0);
}

// 1 where p sees the shadow view's origin, 0 where something nearer covers it.
fn shadow_visibility(view_index: u32, layer: u32, p: vec3<f32>) -> f32 {
    let view = shadow_views[view_index];
    let clip = view.clip_from_world * vec4<f32>(p, 1.0);
    let ndc = clip.xyz / clip.w;
    if any(abs(ndc.xy) > vec2<f32>(1.0)) || ndc.z > 1.0 {
        return 1.0;
    }
    let res = params.shadow_resolution;
    let uv = vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5);
    let texel = min(vec2<u32>(uv * f32(res)), vec2<u32>(res - 1u));
    let stored = textureLoad(shadow_maps, texel, layer, 0);
    // Compare linear depths along the view axis, with a bias of a few texels.
    var occluder: f32;
    var receiver: f32;
    var texel_size = view.texel;
    if view.origin.w > 0.5 {
        occluder = view.near * view.far / (view.far - stored * (view.far - view.near));
        receiver = dot(p - view.origin.xyz, view.axis.xyz);
        texel_size *= receiver;
    } else {
        occluder = view.near + stored * (view.far - view.near);
        receiver = view.near + ndc.z * (view.far - view.near);
    }
    return select(0.0, 1.0, receiver <= occluder + 2.0 * texel_size);
}

// Offsets a receiver along its normal by about two shadow texels, against self-shadowing.
fn shadow_point(x: vec3<f32>, n: vec3<f32>, distance: f32) -> vec3<f32> {
    let texel = 2.0 * max(distance, 1e-4) / f32(params.shadow_resolution);
    return x + n * 2.0 * texel;
}

fn cube_visibility(view_base: u32, layer: u32, eye: vec3<f32>, x: vec3<f32>, n: vec3<f32>) -> f32 {
    let p = shadow_point(x, n, distance(eye, x));
    let face = cube_face(p - eye);
    return shadow_visibility(view_base + face, layer + face, p);
}

fn direct_light(m: Material, x: vec3<f32>, n: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    for (var i = 0u; i < params.light_count; i += 1u) {
        let l = lights[i];
        var wi: vec3<f32>;
        var li: vec3<f32>;
        var v: f32;
        if l.kind == LIGHT_DIRECTIONAL {
            wi = -l.direction.xyz;
            li = l.radiance.rgb;
            if dot(n, wi) <= 0.0 {
                continue;
            }
            let view = shadow_views[l.shadow_layer];
            v = shadow_visibility(l.shadow_layer, l.shadow_layer, x + n * 2.0 * view.texel);
        } else {
            let to_light = l.position.xyz - x;
            let d2 = max(dot(to_light, to_light), 1e-12);
            wi = to_light * inverseSqrt(d2);
            if dot(n, wi) <= 0.0 {
                continue;
            }
            li = l.radiance.rgb / d2;
            if l.kind == LIGHT_SPOT {
                let c = dot(-wi, l.direction.xyz);
                let a = clamp((c - l.cos_outer) / max(l.cos_inner - l.cos_outer, 1e-6), 0.0, 1.0);
                li *= select(a * a, select(0.0, 1.0, c >= l.cos_outer), l.cos_inner <= l.cos_outer);
            }
            v = cube_visibility(l.shadow_layer, l.shadow_layer, l.position.xyz, x, n);
        }
        sum += bsdf_eval(m, n, wo, wi) * li * (dot(n, wi) * v);
    }
    return sum;
}

// This iteration's sample on the emissive surfaces: a point light-like term weighted by the
// area pdf, so the average over iterations converges to the area light's soft shadow.
fn area_light(m: Material, x: vec3<f32>, n: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    if params.area_position.w < 0.5 {
        return vec3<f32>(0.0);
    }
    let y = params.area_position.xyz;
    let to_light = y - x;
    let d2 = max(dot(to_light, to_light), 1e-12);
    let wi = to_light * inverseSqrt(d2);
    let cos_x = dot(n, wi);
    let cos_y = dot(params.area_normal.xyz, -wi);
    if cos_x <= 0.0 || cos_y <= 0.0 {
        return vec3<f32>(0.0);
    }
    let v = cube_visibility(params.area_view, params.area_layer, y, x, n);
    return bsdf_eval(m, n, wo, wi) * params.area_weight.rgb * (cos_x * cos_y * v / d2);
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= params.size) {
        return;
    }
    let pixel = vec2<i32>(id.xy);
    let gp = textureLoad(gbuffer_position, pixel, 0);
    var sample = vec3<f32>(0.0);
    if gp.w != 0.0 {
        let gn = textureLoad(gbuffer_normal, pixel, 0);
        let x = gp.xyz;
        let n = gn.xyz;
        let m = materials[u32(abs(gp.w)) - 1u];
        let wo = normalize(params.camera_position.xyz - x);
        if gp.w > 0.0 {
            sample += m.emissive.rgb;
        }
        sample += direct_light(m, x, n, wo) + area_light(m, x, n, wo);
    }
    samples[id.y * params.size.x + id.x] = vec4<f32>(sample, 1.0);
}
