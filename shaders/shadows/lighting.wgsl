// Light arriving at a surface point straight from the lights: emission, punctual lights with
// their shadow maps, and this iteration's area-light sample. Shared by the camera's G-buffer
// points and the importons reached through specular surfaces.
#define_import_path bevy_rppm::lighting

#import bevy_rppm::common::{Material, Light, IterationParams, LIGHT_SPOT, LIGHT_DIRECTIONAL, face_of}
#import bevy_rppm::bsdf::bsdf_eval
#import bevy_rppm::scene::{shadow_views, lights}

@group(1) @binding(0) var<uniform> params: IterationParams;
@group(2) @binding(2) var shadow_maps: texture_depth_2d_array;

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
    let face = face_of(p - eye);
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

// Radiance leaving x towards wo by emission (front faces only) and direct light.
fn surface_light(m: Material, x: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, front: bool) -> vec3<f32> {
    let emitted = select(vec3<f32>(0.0), m.emissive.rgb, front);
    if params.direct_photons != 0u {
        return emitted;
    }
    return emitted + direct_light(m, x, n, wo) + area_light(m, x, n, wo);
}
