// One sample of a light as a shading point sees it: punctual lights and a lamp's sphere.
#define_import_path bevy_rppm::light_samples

#import bevy_rppm::common::{Light, PI, LIGHT_SPOT, LIGHT_DIRECTIONAL, basis_around}
#import bevy_rppm::sampling::{random, sphere_cap, cone_local}

// Light arriving at x from one sample of a light: from direction `wi`, `distance` away (1e30:
// a direction), `li` the radiance times the sample's weight. The BSDF and the cosine are
// applied by the caller, or only the cosine's sign where the sample was drawn by cosine.
struct LightSample {
    wi: vec3<f32>,
    distance: f32,
    li: vec3<f32>,
    cosine_drawn: bool,
    // An emitter's density as `emitter_density` gives it, for MIS (0: not an emitter).
    density: f32,
}

fn no_light() -> LightSample {
    return LightSample(vec3<f32>(0.0, 0.0, 1.0), 1.0e30, vec3<f32>(0.0), false, 0.0);
}

// Punctual light `l` seen from x; `rng` draws a point on the sphere of a light with a radius
// (traced shadows only: shadow maps see its centre).
fn punctual_sample(l: Light, x: vec3<f32>, rng: ptr<function, u32>) -> LightSample {
    if l.kind == LIGHT_DIRECTIONAL {
        return LightSample(-l.direction.xyz, 1.0e30, l.radiance.rgb, false, 0.0);
    }
    let to_light = l.position.xyz - x;
    let d2 = max(dot(to_light, to_light), 1e-12);
    var s = LightSample(to_light / sqrt(d2), sqrt(d2), l.radiance.rgb / d2, false, 0.0);
    s.li *= spot_falloff(l, -s.wi);
#ifdef TRACED_SHADOWS
    let radius = l.position.w;
    let one_minus = sphere_cap(radius, d2);
    if one_minus > 0.0 {
        // A direction in the cone the sphere subtends, uniform in solid angle Ω: the sphere's
        // radiance I/(πR²) times Ω averages to I/d² (and the spot's falloff stays that of
        // the centre).
        let sin2 = radius * radius / d2;
        let dir = basis_around(s.wi) * cone_local(one_minus, vec2<f32>(random(rng), random(rng)));
        s.li *= 2.0 * one_minus / sin2;
        let b = dot(dir, to_light);
        s.distance = b - sqrt(max(b * b - (d2 - radius * radius), 0.0));
        s.wi = dir;
#ifdef SPHERE_LIGHTS
        // For MIS where camera paths also meet the sphere (`sphere_lights_met`).
        s.density = 1.0 / (2.0 * PI * one_minus);
#endif
    }
#endif
    return s;
}

// A spot light's falloff toward `dir` (from the light; 1 for other lights).
fn spot_falloff(l: Light, dir: vec3<f32>) -> f32 {
    if l.kind != LIGHT_SPOT {
        return 1.0;
    }
    let c = dot(dir, l.direction.xyz);
    let a = clamp((c - l.cos_outer) / max(l.cos_inner - l.cos_outer, 1e-6), 0.0, 1.0);
    return select(a * a, select(0.0, 1.0, c >= l.cos_outer), l.cos_inner <= l.cos_outer);
}

#ifdef SPHERE_LIGHTS_SEEN
// The sphere light `l` (a punctual light's radius) as a ray from x along d meets it before
// t_max: its radiance I/(πR²), a spot's falloff that of its centre, as its shadow rays see
// it, and (w) the cap 1 − cos θ it subtends from x; 0 where the ray misses it. The sphere
// blocks nothing, as Bevy's lights do not.
fn sphere_met(l: Light, x: vec3<f32>, d: vec3<f32>, t_max: f32) -> vec4<f32> {
    let r = l.position.w;
    if l.kind == LIGHT_DIRECTIONAL || r <= 0.0 {
        return vec4<f32>(0.0);
    }
    let to_light = l.position.xyz - x;
    let d2 = dot(to_light, to_light);
    let b = dot(d, to_light);
    let disc = b * b - (d2 - r * r);
    let cap = sphere_cap(r, d2);
    if cap <= 0.0 || b <= 0.0 || disc <= 0.0 || b - sqrt(disc) >= t_max {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(l.radiance.rgb / (PI * r * r) * spot_falloff(l, -to_light * inverseSqrt(d2)), cap);
}
#endif
