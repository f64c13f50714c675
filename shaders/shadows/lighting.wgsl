// Light arriving at a surface point straight from the lights: emission, punctual lights and
// the emissive surfaces, shadowed. With TRACED_SHADOWS (whenever the view has a deep cubemap)
// shadows are rays traced through it, toward points on the emitters drawn per pixel and
// iteration, so direct light converges to the exact answer; else shadow maps (and one
// area-light sample per iteration). Shared by the camera's G-buffer points and the importons
// reached through specular surfaces.
#define_import_path bevy_rppm::lighting

#import bevy_rppm::common::{Material, Light, IterationParams, PI, LIGHT_DIRECTIONAL, DELTA_ROUGHNESS, face_of, cosine_direction, luminance}
#import bevy_rppm::sampling::{random, spherical_triangle, bilinear_sample, bilinear_density}
#import bevy_rppm::bsdf::{bsdf_eval, translucency, layered}
#import bevy_rppm::light_samples::{LightSample, no_light, punctual_sample}
#ifdef SPHERE_LIGHTS_SEEN
#import bevy_rppm::light_samples::sphere_met
#import bevy_rppm::camera::camera_ray_at
#endif
#import bevy_rppm::scene::{shadow_views, lights, triangles, triangle_at, face_normal, material_at, emitters, light_cdf, find_source, triangle_point, uniform_barycentrics, part_barycentrics}
#ifdef TRACED_SHADOWS
#import bevy_rppm::cubemap::occluded
#ifdef PANES
#import bevy_rppm::pane_rays::through_panes
#import bevy_rppm::panes::panes_on
#endif
#ifdef IMPORTONS
#import bevy_rppm::mis::{path_f, drawn_pdf, power_heuristic}
#else ifdef EMITTER_RAYS
#import bevy_rppm::mis::power_heuristic
#endif
#ifdef EMITTER_RAYS
#import bevy_rppm::cubemap::{trace_ray, NO_HIT}
#import bevy_rppm::common::MATERIAL_UNLIT
#endif
#endif

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

#ifdef TRACED_SHADOWS
// What reaches x (on triangle `origin_triangle`) from the light `distance` along `dir` (1e30:
// a direction): 1 where nothing lies between, 0 otherwise; with PANES, light through panes
// too where `through` (`through_panes`; w: 1 where it came through one).
fn visibility(x: vec3<f32>, dir: vec3<f32>, distance: f32, origin_triangle: u32, through: bool) -> vec4<f32> {
    let t_min = params.scene_sphere.w * 1e-6;
#ifdef PANES
    // One ray walk for both: a scene with panes finds the nearest hit of every shadow ray.
    return through_panes(x, dir, distance, origin_triangle, t_min, through);
#else
    let t_max = select(distance * (1.0 - 1e-4), 1.0e30, distance >= 1.0e30);
    return vec4<f32>(vec3<f32>(select(1.0, 0.0, occluded(x, dir, t_min, t_max, origin_triangle))), 0.0);
#endif
}
#endif

// Past this many punctual lights, traced shadows draw this many of them by power per pixel
// and iteration instead of tracing a ray to each: the cost stays that of a few lights, the
// average over iterations the same.
const MANY_LIGHTS: u32 = 8u;
#ifdef EMITTERS
// Points drawn on the emitters per pixel and iteration where no camera path goes on: one a
// pixel left emitter-lit rooms speckled after 20 iterations (README). A pixel that splits
// its camera path shares them among its paths (`emitter_draws`, set by eye_paths.wgsl).
const EMITTER_DRAWS: u32 = 4u;
var<private> emitter_draws: u32 = EMITTER_DRAWS;
// Of how many points on the emitters each draw is chosen (`resampled_emitter`).
const CANDIDATES: u32 = 4u;
#endif

#ifdef TRACED_SHADOWS
// How many of a point's traced-shadow samples draw light i, on average: 1, or past
// MANY_LIGHTS lights MANY_LIGHTS of them drawn by power.
fn light_samples(i: u32) -> f32 {
    if params.light_count <= MANY_LIGHTS {
        return 1.0;
    }
    let total = light_cdf[params.light_count - 1u];
    let p = (light_cdf[i] - select(0.0, light_cdf[max(i, 1u) - 1u], i > 0u)) / total;
    return f32(MANY_LIGHTS) * max(p, 1e-12);
}
#endif

#ifdef SPHERE_LIGHTS_SEEN
// The sphere lights a ray from x along d sees before t_max, where no shadow ray could have
// drawn them (the camera's own rays, and rays a smooth surface reflects or refracts).
fn sphere_lights_seen(x: vec3<f32>, d: vec3<f32>, t_max: f32) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    for (var i = 0u; i < params.light_count; i += 1u) {
        sum += sphere_met(lights[i], x, d, t_max).rgb;
    }
    return sum;
}

// The sphere lights that the camera's ray through this pixel (jittered as the G-buffer is,
// and by `shading_jitter`) sees before its surface: Bevy draws no light, but a light with a
// radius is a lamp's bulb, which the references (and a camera) see.
fn spheres_in_pixel(pixel: vec2<u32>, gp: vec4<f32>) -> vec3<f32> {
    let ray = camera_ray_at(params, vec2<f32>(pixel) + 0.5 + params.shading_jitter);
    let far = select(1.0e30, dot(gp.xyz - ray.origin, ray.direction), gp.w != 0.0);
    return sphere_lights_seen(ray.origin, ray.direction, far);
}
#endif

#ifdef SPHERE_LIGHTS
// Light from the sphere lights that a camera path's ray from x along d meets before `t_max`,
// having left a rough vertex whose shadow rays sample them too: each weighted by the power
// heuristic against those (a sphere seen in a sharp lobe is found by the path far more often
// than by a point drawn on it).
fn sphere_lights_met(x: vec3<f32>, d: vec3<f32>, t_max: f32, drawn_density: f32) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    for (var i = 0u; i < params.light_count; i += 1u) {
        let met = sphere_met(lights[i], x, d, t_max);
        if met.w > 0.0 {
            let density = light_samples(i) / (2.0 * PI * met.w);
            sum += met.rgb * power_heuristic(drawn_density, density);
        }
    }
    return sum;
}
#endif

#ifdef TRACED_SHADOWS
#ifdef EMITTERS
// The emissive triangles seen from x (normal n): one triangle drawn by power, one point on it
// by area, or where `by_solid_angle` by the solid angle it subtends, whose weight stays bounded
// however near x is (a floor beside a glowing box); MIS keeps the area's density, which its
// weights are computed with for both strategies.
fn emitter_sample(x: vec3<f32>, n: vec3<f32>, origin_triangle: u32, by_solid_angle: bool, rng: ptr<function, u32>) -> LightSample {
    // The emitters' entries of the source CDF: past the lights, before the sky.
    let end = params.source_count - u32(params.sky.w > 0.5);
    if end <= params.light_count {
        return no_light();
    }
    let first = select(0.0, light_cdf[params.light_count - 1u], params.light_count > 0u);
    let share = light_cdf[end - 1u] - first;
    if share <= 0.0 {
        return no_light();
    }
    let index = find_source(first + random(rng) * share, params.light_count, end - 1u);
    let previous = select(0.0, light_cdf[index - 1u], index > 0u);
    let p = max(light_cdf[index] - previous, 1e-12) / share;
    let e = emitters[index - params.light_count];
    let t = triangle_at(e.triangle);
    let normal = face_normal(t);
    let u = vec2<f32>(random(rng), random(rng));
    if dot(normal, x - t.position_a) <= 0.0 || e.triangle == origin_triangle {
        return no_light();
    }
    var part = uniform_barycentrics(u.x, u.y);
    var solid_angle = 0.0;
    if by_solid_angle {
        // Arvo's sampling loses precision on a thin or far triangle, where area does well.
        let a = triangle_point(t, part_barycentrics(e.part, vec2<f32>(0.0)));
        let b = triangle_point(t, part_barycentrics(e.part, vec2<f32>(1.0, 0.0)));
        let c = triangle_point(t, part_barycentrics(e.part, vec2<f32>(0.0, 1.0)));
        // Warped toward x's cosine at the corners (pbrt-v4), as area sampling partly is.
        let cosines = max(abs(vec3<f32>(dot(n, normalize(a - x)), dot(n, normalize(b - x)), dot(n, normalize(c - x)))), vec3<f32>(0.01));
        let warp = vec4<f32>(cosines.y, cosines.y, cosines.x, cosines.z);
        let v = bilinear_sample(u, warp);
        let drawn = spherical_triangle(a, b, c, x, v);
        if drawn.z > 3e-4 && drawn.z < 6.2 {
            part = drawn.xy;
            solid_angle = drawn.z / bilinear_density(v, warp);
        }
    }
    let b = part_barycentrics(e.part, part);
    let y = triangle_point(t, b);
    let to_light = y - x;
    let d2 = max(dot(to_light, to_light), 1e-12);
    let wi = to_light * inverseSqrt(d2);
    let cos_y = -dot(normal, wi);
    if cos_y <= 0.0 {
        return no_light();
    }
    let radiance = material_at(e.triangle, b, 0.0).emissive.rgb;
    let weight = select(cos_y * e.area / d2, solid_angle, solid_angle > 0.0) / p;
    return LightSample(wi, sqrt(d2), radiance * weight, false, emitter_density(radiance, d2, cos_y));
}

#ifdef EMITTER_RAYS
// The emitter met by a ray drawn by cosine around n (a sample of radiance × π, the BSDF and
// the cosine's sign applied by the caller), or none. A large emitter close by (a glowing ball
// on the floor) covers much of the hemisphere, but `emitter_sample` draws it a triangle at a
// time by power: the near triangle, drawn rarely, weighed so much that it made fireflies.
fn emitter_ray(x: vec3<f32>, n: vec3<f32>, origin_triangle: u32, rng: ptr<function, u32>) -> LightSample {
    let wi = cosine_direction(n, vec2<f32>(random(rng), random(rng)));
    let hit = trace_ray(x, wi, params.scene_sphere.w * 1e-6, 1.0e30, origin_triangle);
    if hit.triangle == NO_HIT {
        return no_light();
    }
    let t = triangle_at(hit.triangle);
    let cos_y = -dot(face_normal(t), wi);
    let m = material_at(hit.triangle, hit.uv, 0.0);
    // An unlit surface shows its colour as emission but lights nothing (no emitter).
    if cos_y <= 0.0 || all(m.emissive.rgb <= vec3<f32>(0.0)) || (m.flags & MATERIAL_UNLIT) != 0u {
        return no_light();
    }
    let radiance = m.emissive.rgb;
    let d2 = hit.t * hit.t;
    return LightSample(wi, hit.t, radiance * PI, true, emitter_density(radiance, d2, cos_y));
}
#endif

// The density (solid angle) of drawing an emitter's point of radiance L at distance² d2 and
// cosine cos_y, were every emitter drawn by its power: exact for untextured emitters, and the
// same function for both strategies of MIS (what keeps their weights summing to 1).
fn emitter_density(radiance: vec3<f32>, d2: f32, cos_y: f32) -> f32 {
    return PI * luminance(radiance) * d2 / max(params.emitter_power * cos_y, 1e-30);
}

// Resampled importance sampling (Talbot et al. 2005): of CANDIDATES points drawn on the
// emitters, one chosen by the light it brings x unshadowed (BSDF and cosine included: faces
// turned away are never chosen), weighed by their mean weight over its own; with its BSDF
// (`f`), evaluated already. MIS against the cosine ray keeps the draw's density: its weights
// still sum to 1.
struct Resampled {
    sample: LightSample,
    f: vec3<f32>,
}

fn resampled_emitter(m: Material, x: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, origin_triangle: u32, rng: ptr<function, u32>) -> Resampled {
    var chosen = Resampled(no_light(), vec3<f32>(0.0));
    var chosen_weight = 0.0;
    var total = 0.0;
    for (var c = 0u; c < CANDIDATES; c += 1u) {
        let s = emitter_sample(x, n, origin_triangle, true, rng);
        let f = bsdf_eval(m, n, wo, s.wi);
        let w = luminance(f * s.li) * abs(dot(n, s.wi));
        total += w;
        if w > 0.0 && (c == 0u || random(rng) * total < w) {
            chosen = Resampled(s, f);
            chosen_weight = w;
        }
    }
    chosen.sample.li *= select(0.0, total / (f32(CANDIDATES) * chosen_weight), chosen_weight > 0.0);
    return chosen;
}
#endif
#endif

// Radiance leaving x (on triangle `origin_triangle`) towards wo by emission (front faces only)
// and direct light, from the emitters and the sky too when `emitters` (camera paths that go on
// past x find them themselves). Where `mis`, x is a rough vertex the path goes on from
// (mis.wgsl): its f includes rough refraction, and the emitters are sampled too, weighted
// against the path's own chance of finding them. `rng` draws the samples.
fn surface_light(m: Material, x: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, front: bool, origin_triangle: u32, emitters: bool, mis: bool, rng: ptr<function, u32>, blocked: ptr<function, u32>) -> vec3<f32> {
    let emitted = select(vec3<f32>(0.0), m.emissive.rgb, front);
    // A smooth glass or mirror vertex a path goes on from (mis implies a rough one) reflects
    // no light sample: it draws none, so the pixel's stratified draws go to the path's Fresnel
    // choices instead (sparkles in a glass ball lit by sphere lights).
    let delta = !emitters && m.perceptual_roughness < DELTA_ROUGHNESS && m.clearcoat.x <= 0.0 && translucency(m) <= 0.0;
    if params.direct_photons != 0u || delta {
        return emitted;
    }
    var sum = emitted;
#ifdef TRACED_SHADOWS
    // One loop, one shadow ray and one BSDF in the code for every kind of light: each copy
    // of a ray walk costs seconds of shader compilation on a CPU rasteriser. Its samples: the
    // punctual lights (or MANY_LIGHTS of them drawn by power), then the sky, then the emitters.
    let many = params.light_count > MANY_LIGHTS;
    let punctual = select(params.light_count, MANY_LIGHTS, many);
    // EMITTER_DRAWS where no camera path (whose MIS weighs one) goes on; none without emitters.
#ifdef EMITTERS
    let draws = select(1u, emitter_draws, emitters && !mis);
#else
    let draws = 0u;
#endif
    var samples = punctual + select(0u, 1u + draws, emitters || mis);
#ifdef EMITTER_RAYS
    // Where no camera path goes on, a ray drawn by cosine finds the emitters too (MIS).
    let rays = emitters && !mis;
    samples += u32(rays);
#endif
#ifdef NORMAL_MAP
    // An opaque surface takes no light from behind its own triangle, whatever its bent
    // normal says: the shadow ray leaves that triangle, so it would not see the wall it is on
    // (the sun through a one-sided wall's back onto its bumps).
    let tri = triangle_at(origin_triangle);
    let face = cross(tri.position_b - tri.position_a, tri.position_c - tri.position_a);
    let outside = select(-face, face, dot(face, wo) >= 0.0);
    let opaque = m.specular_transmission == 0.0 && translucency(m) == 0.0;
#endif
#ifdef SPHERE_LIGHTS
    var spheres: array<vec4<f32>, MANY_LIGHTS>;
    var sphere_directions: array<vec3<f32>, MANY_LIGHTS>;
    var sphere_count = 0u;
#endif
    for (var k = 0u; k < samples; k += 1u) {
        var s = no_light();
        var light = 32u;
        // The sample's BSDF, where its draw evaluated it already (resampling).
        var f = vec3<f32>(0.0);
        var evaluated_f = false;
        if k < punctual {
            var i = k;
            if many {
                let total = light_cdf[params.light_count - 1u];
                i = find_source(random(rng) * total, 0u, params.light_count - 1u);
            }
            s = punctual_sample(lights[i], x, rng);
            let drawn = light_samples(i);
            s.li /= drawn;
            s.density *= drawn;
            light = i;
        } else if k == punctual {
#ifdef SKY
            if !emitters {
                continue;
            }
            // One direction drawn by cosine around n (pdf cos/π), a ray to infinity; through
            // to the other side by the share of diffuse light that goes through.
            var wi = cosine_direction(n, vec2<f32>(random(rng), random(rng)));
            var li = params.sky.rgb * PI;
            let through = translucency(m);
            if through > 0.0 {
                let back = random(rng) < through;
                wi = select(wi, -wi, back);
                li /= select(1.0 - through, through, back);
            }
            s = LightSample(wi, 1.0e30, li, true, 0.0);
#endif
#ifdef EMITTERS
        } else if k <= punctual + draws {
            if mis {
                s = emitter_sample(x, n, origin_triangle, false, rng);
            } else {
                let r = resampled_emitter(m, x, n, wo, origin_triangle, rng);
                s = r.sample;
                f = r.f;
                evaluated_f = true;
            }
            s.li /= f32(draws);
            s.density *= f32(draws);
#endif
        } else {
#ifdef EMITTER_RAYS
            s = emitter_ray(x, n, origin_triangle, rng);
#endif
        }
        if all(s.li <= vec3<f32>(0.0)) {
            continue;
        }
#ifdef NORMAL_MAP
        if opaque && dot(outside, s.wi) <= 0.0 {
            continue;
        }
#endif
        // |cos|: light from behind reaches only what lets diffuse light through (bsdf_eval).
        let c = abs(dot(n, s.wi));
        if !evaluated_f {
            var evaluated = m;
#ifdef IMPORTONS
            if mis {
                evaluated = layered(m);
            }
#endif
            f = bsdf_eval(evaluated, n, wo, s.wi);
        }
#ifdef IMPORTONS
        if mis {
            f = path_f(f, m, n, wo, s.wi, front);
            if s.density > 0.0 && k >= punctual {
                f *= power_heuristic(s.density, drawn_pdf(*blocked, m, x, n, wo, s.wi, front));
            }
        }
#endif
#ifdef EMITTER_RAYS
        // The emitter sample against the cosine ray, each weighed by the other's density.
        let by_cosine = max(dot(n, s.wi), 0.0) / PI;
        if rays && k > punctual + draws {
            f *= power_heuristic(by_cosine, s.density * f32(draws));
        }
#endif
        let lit = f * s.li * select(c, sign(c), s.cosine_drawn);
        // No shadow ray where nothing would arrive (behind an opaque surface, outside a
        // cone, a delta lobe).
        if any(lit > vec3<f32>(0.0)) {
            // Light through panes too (PANES), unless a camera path that goes on from here
            // finds it through them (MIS at a rough vertex), or panes are off (`panes_on`).
            var through = !(mis && s.density > 0.0);
#ifdef PANES
            through = through && panes_on(params);
#endif
            var seen = vec3<f32>(1.0);
            // The cosine ray's emitter is its nearest hit: nothing lies between.
            if k <= punctual + draws {
                let walk = visibility(x, s.wi, s.distance, origin_triangle, through);
                seen = walk.rgb;
#ifdef EMITTER_RAYS
                // The ray stops at a pane: light through one is the emitter sample's alone.
                if rays && k > punctual && walk.w == 0.0 {
                    seen *= power_heuristic(s.density, by_cosine);
                }
#endif
            }
            if all(seen == vec3<f32>(0.0)) && k < punctual && light < 32u {
                *blocked |= 1u << light;
            }
#ifdef SPHERE_LIGHTS
            if mis && s.density > 0.0 && k < punctual {
                // Weighed once every light's shadow ray is known (the density the path
                // draws with depends on which are blocked).
                spheres[sphere_count] = vec4<f32>(lit * seen, s.density);
                sphere_directions[sphere_count] = s.wi;
                sphere_count += 1u;
                continue;
            }
#endif
            sum += lit * seen;
        }
    }
#ifdef SPHERE_LIGHTS
    for (var j = 0u; j < sphere_count; j += 1u) {
        sum += spheres[j].rgb * power_heuristic(spheres[j].w, drawn_pdf(*blocked, m, x, n, wo, sphere_directions[j], front));
    }
#endif
#else
    for (var i = 0u; i < params.light_count; i += 1u) {
        let l = lights[i];
        let s = punctual_sample(l, x, rng);
        let lit = bsdf_eval(m, n, wo, s.wi) * s.li * max(dot(n, s.wi), 0.0);
        if all(lit <= vec3<f32>(0.0)) {
            continue;
        }
        if l.kind == LIGHT_DIRECTIONAL {
            let view = shadow_views[l.shadow_layer];
            sum += lit * shadow_visibility(l.shadow_layer, l.shadow_layer, x + n * 2.0 * view.texel);
        } else {
            sum += lit * cube_visibility(l.shadow_layer, l.shadow_layer, l.position.xyz, x, n);
        }
    }
    if emitters {
        sum += area_light(m, x, n, wo);
    }
#endif
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
