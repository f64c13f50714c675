// Local illumination: emission seen by the camera plus direct light from every light, this
// iteration's sample before photons are added. With IMPORTONS, a pixel that sees a specular
// surface (mirror, glass) follows the camera path to the first non-specular surface, lights
// it the same way, and leaves an importon there for indirect splatting.
#import bevy_rppm::common::{Material, IterationParams, Importon, NO_IMPORTON, gather_radius}
#import bevy_rppm::camera::toward_eye
#import bevy_rppm::sampling::{random, pcg_hash, stratified_draws}
#import bevy_rppm::scene::{triangle_at, gbuffer_material, gbuffer_triangle, resolve_surface, kernel_normal, material_at, as_seen_from, normal_at, interpolated_normal}
#import bevy_rppm::lighting::{params, surface_light}
#ifdef EMITTERS
#import bevy_rppm::lighting::{emitter_draws, EMITTER_DRAWS}
#endif
#ifdef IMPORTONS
#import bevy_rppm::bsdf::{glass_share, stores_photons}
#import bevy_rppm::microfacet::fresnel_dielectric
#import bevy_rppm::eye_bounce::{Bounce, delta_share, lobe_bounce, next_bounce}
#import bevy_rppm::footprint::{Footprint, footprint_from_camera, footprint_transfer, footprint_bounce, footprint_width}
#ifdef CLEARCOAT
#import bevy_rppm::bsdf::{coat_traced, scatter_coat}
#endif
#ifdef GLOSSY_TRACED
#import bevy_rppm::bsdf::{glossy_traced, scatter_glossy}
#endif
#import bevy_rppm::common::{DELTA_ROUGHNESS, luminance}
#import bevy_rppm::cubemap::{cubemap, trace_ray, NO_HIT}
#ifdef ABSORPTION
#import bevy_rppm::scene::medium_after
#endif
#ifdef TRACED_SHADOWS
#import bevy_rppm::mis::{mis_vertex, path_pdf, power_heuristic}
#endif
#ifdef EMITTERS
#import bevy_rppm::lighting::emitter_density
#import bevy_rppm::common::MATERIAL_UNLIT
#endif
#ifdef LIGHT_GUIDE
#import bevy_rppm::mis::{guide_share, guided_bounce}
#endif
#ifdef SPHERE_LIGHTS
#import bevy_rppm::lighting::sphere_lights_met
#endif
#endif
#ifdef SPHERE_LIGHTS_SEEN
#import bevy_rppm::lighting::{sphere_lights_seen, spheres_in_pixel}
#endif
#ifdef SHADING_POINTS
#import bevy_rppm::cubemap::camera_hit
#import bevy_rppm::surface::{surface_marks, packed_surface, same_surface}
#endif

@group(2) @binding(0) var gbuffer_position: texture_2d<f32>;
@group(2) @binding(1) var gbuffer_normal: texture_2d<f32>;
@group(2) @binding(3) var<storage, read_write> samples: array<vec4<f32>>;
#ifdef TEXTURED
// Each pixel's `resolve_surface`, which the splat reads.
@group(2) @binding(6) var<storage, read_write> surfaces: array<vec4<u32>>;
#endif
#ifdef IMPORTONS
@group(2) @binding(4) var<storage, read_write> importons: array<Importon>;
// [1]: importons made (read back as `ViewStats::importons`); [2] extra slots taken; [4..7]
// the indirect splat's dispatch, its x set here once an importon exists.
@group(2) @binding(5) var<storage, read_write> importon_stats: array<atomic<u32>, 8>;

// Camera-path vertex from which Russian roulette may end a path.
const EYE_ROULETTE_DEPTH: u32 = 3u;
// Camera paths a pixel traces each iteration where it sees rough glass (frosted, storing no
// photons): the light they bring varies the most of any pixel's, and a path costs less than an
// iteration. 4 beat 1, 2 and 8 at equal time on the frosted scenes (README; not on smooth glass).
const SPLIT_PATHS: u32 = 4u;
// Of those paths, how many leave an importon: the second in a slot past the image's
// (`EXTRA_IMPORTONS` in src/importons/mod.rs) where the buffer has room, else the first alone.
// 2 beat 1 and 4 at equal time on `frosted_lantern` and `frosted_glass` (a gather costs more).
const SPLIT_IMPORTONS: u32 = 2u;

// How far past the G-buffer point a path that went on met the first surface storing photons (0:
// none): where a camera move's reprojection looks for what glass or a mirror shows (accumulate).
var<private> shown_beyond: f32;
#endif

#ifdef REFLECTED_EMISSION
// At smooth glass seen from outside, the share of the camera path that its Fresnel reflection
// carries (glass × F), whose emission the path then looks up along the reflected ray (a
// `peek`) besides going on: the path itself reflects in only F of its tries (water under a
// bright sky panel: about one in 35 saw the panel, a speckle 10x the dim floor behind). 0
// elsewhere (mirrors, rough glass, from inside: left to the path alone).
fn reflection_share(v: Vertex) -> f32 {
    let glass = glass_share(v.m);
    var split = v.front && glass > 0.0 && luminance(v.m.base_color.rgb) * v.m.metallic <= 0.0;
    split = split && v.m.perceptual_roughness < DELTA_ROUGHNESS;
    return select(0.0, glass * fresnel_dielectric(dot(v.wo, v.n), 1.0 / v.m.ior), split);
}
#endif

// A vertex of the camera path: the surface point, its shading normal and material as seen
// from the side the path arrives on, and the direction back along the path.
struct Vertex {
    x: vec3<f32>,
    n: vec3<f32>,
    m: Material,
    front: bool,
    triangle: u32,
    wo: vec3<f32>,
}

// The light the camera path from the G-buffer vertex `first` brings back: emission and direct
// light at its end; with IMPORTONS a path that meets a surface storing no photons goes on
// (emission and punctual lights at glossy vertices on the way) and leaves an importon at its
// first vertex past the G-buffer that stores photons, in `slot` (none: NO_IMPORTON), weighed
// by `share` of the pixel's importons, its gather as wide as the pixel's `Footprint` there.
// One loop for every vertex, so that the lighting and the ray walk are compiled once.
fn camera_path(first: Vertex, slot: u32, share: f32, rng: ptr<function, u32>) -> vec3<f32> {
    var v = first;
    var found = vec3<f32>(0.0);
    var throughput = vec3<f32>(1.0);
#ifdef IMPORTONS
    var bounce = Bounce(vec3<f32>(0.0), vec3<f32>(1.0));
    var length = distance(params.camera_position.xyz, v.x);
    let orthographic = params.orthographic != 0u;
    var fp = Footprint(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), true);
    let t_min = params.scene_sphere.w * 1e-6;
    // Whether the light this path meets next was sampled already (through a rough coat).
    var sampled = false;
    // The density of the path's last direction where the emitters were sampled too (mis.wgsl).
    var drawn_density = 0.0;
#ifdef ABSORPTION
    // σ of the coloured glass the path is in (the camera is outside every medium).
    var medium = vec3<f32>(0.0);
#endif
#ifdef REFLECTED_EMISSION
    // A trace that only looks up the emission along a smooth reflection, its weight, and
    // the bounce the path goes on by after it.
    var peek = false;
    var peek_weight = vec3<f32>(0.0);
    var pending = bounce;
    var pending_sampled = false;
#endif
#ifdef SPHERE_LIGHTS_SEEN
    // Whether the path's last bounce was off a delta lobe, along which it meets the sphere
    // lights with no shadow ray to weigh against.
    var delta = false;
#endif
#endif
    for (var depth = 1u; depth <= params.max_eye_depth; depth += 1u) {
#ifdef IMPORTONS
        if depth > 1u {
            var peeking = false;
#ifdef REFLECTED_EMISSION
            peeking = peek;
#endif
            if all(throughput <= vec3<f32>(0.0)) && !peeking {
                return found;
            }
            let d = bounce.direction;
            let hit = trace_ray(v.x, d, t_min, 1.0e30, v.triangle);
#ifdef REFLECTED_EMISSION
            if peek {
                // The reflected ray's emission (front faces), then back to the path from v.
                var emitted = vec3<f32>(0.0);
                if hit.triangle != NO_HIT {
                    let t = triangle_at(hit.triangle);
                    let front = dot(cross(t.position_b - t.position_a, t.position_c - t.position_a), d) < 0.0;
                    emitted = select(vec3<f32>(0.0), material_at(hit.triangle, hit.uv, 0.0).emissive.rgb, front);
                }
#ifdef SKY
                emitted = select(emitted, params.sky.rgb, hit.triangle == NO_HIT);
#endif
                found += peek_weight * emitted;
#ifdef SPHERE_LIGHTS_SEEN
                found += peek_weight * sphere_lights_seen(v.x, d, select(hit.t, 1.0e30, hit.triangle == NO_HIT));
#endif
                peek = false;
                bounce = pending;
                sampled = pending_sampled;
                depth -= 1u;
                continue;
            }
#endif
            if fp.delta {
                let at = triangle_at(v.triangle);
                if depth == 2u {
                    fp = footprint_transfer(footprint_from_camera(-v.wo, params.pixel_spread, orthographic), -v.wo, length, at);
                }
                fp = footprint_bounce(fp, at, v.x, v.n, v.front, -v.wo, d, select(v.m.ior, 1.0 / v.m.ior, v.front));
            }
#ifdef SPHERE_LIGHTS
            if drawn_density > 0.0 {
                found += throughput * sphere_lights_met(v.x, d, select(hit.t, 1.0e30, hit.triangle == NO_HIT), drawn_density);
            }
#endif
#ifdef SPHERE_LIGHTS_SEEN
            if delta && !sampled {
                found += throughput * sphere_lights_seen(v.x, d, select(hit.t, 1.0e30, hit.triangle == NO_HIT));
            }
#endif
#ifdef ABSORPTION
            throughput *= exp(-medium * hit.t);
#endif
            if hit.triangle == NO_HIT {
#ifdef SKY
                found += select(throughput * params.sky.rgb, vec3<f32>(0.0), sampled);
#endif
                return found;
            }
            let t = triangle_at(hit.triangle);
            length += hit.t;
            fp = footprint_transfer(fp, d, hit.t, t);
            let geometric = cross(t.position_b - t.position_a, t.position_c - t.position_a);
            let front = dot(geometric, d) < 0.0;
            var interpolated = interpolated_normal(t, hit.uv);
            var n = normal_at(hit.triangle, hit.uv, interpolated);
            if !front {
                n = -n;
                interpolated = -interpolated;
            }
            v = Vertex(
                v.x + d * hit.t,
                n,
                as_seen_from(material_at(hit.triangle, hit.uv, 0.0), front),
                front,
                hit.triangle,
                -d,
            );
            if sampled {
                v.m.emissive = vec4<f32>(0.0);
                sampled = false;
            }
#ifdef EMITTERS
            // An emitter the shadow rays drew too; not an unlit surface, which they never draw.
            if drawn_density > 0.0 && front && (v.m.flags & MATERIAL_UNLIT) == 0u {
                let cos_y = abs(dot(normalize(geometric), d));
                let density = emitter_density(v.m.emissive.rgb, hit.t * hit.t, cos_y);
                v.m.emissive = vec4<f32>(v.m.emissive.rgb * power_heuristic(drawn_density, density), v.m.emissive.w);
            }
#endif
#ifdef TRACED_SHADOWS
            drawn_density = 0.0;
#endif
            if stores_photons(v.m) && shown_beyond == 0.0 {
                shown_beyond = length - distance(params.camera_position.xyz, first.x);
            }
            if stores_photons(v.m) && slot != NO_IMPORTON {
                let footprint = footprint_width(fp, d, params.pixel_spread * select(length, 1.0, orthographic));
                let radius = gather_radius(params, params.splat_radius, footprint);
                importons[slot] = Importon(v.x, v.triangle, interpolated, 0u, throughput * share, radius, v.wo, 0u);
                atomicAdd(&importon_stats[1], 1u);
                atomicMax(&importon_stats[4], (params.size.x * params.size.y + 63u) / 64u);
            }
        }
        let ends = stores_photons(v.m);
#else
        let ends = true;
#endif
        // Mode Indirect: Bevy renders the first hit's emission and direct light itself.
        // Where the path goes on, the sky and emitters are found by the path itself, and at a
        // rough vertex (not the last, whose path cannot go on) the emitters by MIS too.
        let lit = depth > 1u || params.indirect_only == 0u;
        var mis = false;
#ifdef IMPORTONS
#ifdef TRACED_SHADOWS
        mis = lit && !ends && mis_vertex(v.m) && depth < params.max_eye_depth && params.direct_photons == 0u;
#endif
#endif
        // The punctual lights a shadow ray found blocked here (LIGHT_GUIDE draws toward them).
        var blocked = 0u;
        if lit {
            found += throughput * surface_light(v.m, v.x, v.n, v.wo, v.front, v.triangle, ends, mis, rng, &blocked);
        }
        if ends {
#ifdef IMPORTONS
#ifdef CLEARCOAT
            // The camera's first hit gathers photons without a smooth coat's lobe (the splat's
            // `bsdf_gathered`): the path follows the coat instead. Its lights were sampled
            // here through the coat unless it is a mirror (or Bevy or photons give them).
            if depth == 1u && coat_traced(v.m) {
                let s = scatter_coat(v.m, v.n, v.wo, rng);
                bounce = Bounce(s.direction, s.weight);
                throughput *= s.weight;
                sampled = v.m.clearcoat.y >= DELTA_ROUGHNESS && params.indirect_only == 0u && params.direct_photons == 0u;
#ifdef SPHERE_LIGHTS_SEEN
                delta = v.m.clearcoat.y < DELTA_ROUGHNESS;
#endif
                continue;
            }
#endif
#ifdef GLOSSY_TRACED
            // Likewise a glossy lobe too sharp to gather over (`glossy_traced`).
            if depth == 1u && glossy_traced(v.m) {
                let s = scatter_glossy(v.m, v.n, v.wo, rng);
                bounce = Bounce(s.direction, s.weight);
                throughput *= s.weight;
                sampled = params.indirect_only == 0u && params.direct_photons == 0u;
#ifdef SPHERE_LIGHTS_SEEN
                delta = false;
#endif
                continue;
            }
#endif
            // A smooth surface only partly glass or metal (Bevy's specular transmission or
            // metallic under 1): photons are gathered on its other lobes, and the path goes on
            // through its delta lobes from the first hit (later vertices keep one importon).
            let mirror_like = v.m.perceptual_roughness < DELTA_ROUGHNESS;
            if depth == 1u && mirror_like && delta_share(v.m) > 0.0 && depth < params.max_eye_depth {
                bounce = next_bounce(v.m, -v.wo, v.n, v.front, rng);
                throughput *= bounce.weight;
#ifdef SPHERE_LIGHTS_SEEN
                delta = true;
#endif
#ifdef ABSORPTION
                medium = medium_after(medium, v.m, v.front, dot(bounce.direction, v.n) < 0.0);
#endif
                continue;
            }
#endif
            return found;
        }
#ifdef IMPORTONS
        var guided = false;
#ifdef LIGHT_GUIDE
        let share = select(0.0, guide_share(blocked, v.m, v.x, v.n, v.front), mis);
        if share > 0.0 {
            let by_guide = random(rng) < share;
            var drawn = Bounce(v.n, vec3<f32>(1.0));
            if !by_guide {
                drawn = lobe_bounce(v.m, -v.wo, v.n, v.front, rng);
            }
            let g = guided_bounce(blocked, v.m, v.x, v.n, v.wo, v.front, share, drawn.direction, drawn.weight, by_guide, rng);
            bounce = Bounce(g.direction, g.weight);
            drawn_density = g.density;
            guided = true;
        }
#endif
        var reflected_share = 0.0;
#ifdef SPHERE_LIGHTS_SEEN
        delta = !guided && v.m.perceptual_roughness < DELTA_ROUGHNESS;
#endif
        if !guided {
            bounce = next_bounce(v.m, -v.wo, v.n, v.front, rng);
#ifdef REFLECTED_EMISSION
            reflected_share = reflection_share(v);
#endif
#ifdef TRACED_SHADOWS
            if mis {
                drawn_density = path_pdf(v.m, v.n, v.wo, bounce.direction, v.front);
            }
#endif
        }
        let arriving = throughput;
        throughput *= bounce.weight;
#ifdef ABSORPTION
        medium = medium_after(medium, v.m, v.front, dot(bounce.direction, v.n) < 0.0);
#endif
        // Russian roulette past the first vertices, so that paths trapped in glass (total
        // internal reflection) end early on average yet the estimate keeps its mean.
        var kept = 1.0;
        if depth >= EYE_ROULETTE_DEPTH {
            kept = min(max(throughput.x, max(throughput.y, throughput.z)), 0.95);
            if random(rng) >= kept {
                return found;
            }
            throughput /= kept;
        }
#ifdef REFLECTED_EMISSION
        if reflected_share > 0.0 && depth < params.max_eye_depth {
            // The next trace peeks along the reflection (`reflection_share`); the path goes
            // on from v after it, without that emission if it reflected too.
            let reflected = reflect(-v.wo, v.n);
            peek = true;
            peek_weight = arriving * (reflected_share / kept);
            pending = bounce;
            pending_sampled = all(bounce.direction == reflected);
            bounce = Bounce(reflected, vec3<f32>(1.0));
        }
#endif
#endif
    }
    return found;
}

// How far the camera sees (group 1, binding 1): visible pixels counted by distance from the
// camera, [k] those within (R/2^(k+1), R/2^k] (R the scene's radius; [0] farther too, [15]
// nearer too); photon emission reads it (`emission_disc` in photons/trace.wgsl).
@group(1) @binding(1) var<storage, read_write> seen: array<atomic<u32>, 16>;
var<workgroup> seen_here: array<atomic<u32>, 16>;

// Counts this workgroup's visible pixels into `seen`, one atomic per distance per workgroup.
fn see(pixel: vec2<u32>, lane: u32) {
    if lane < 16u {
        atomicStore(&seen_here[lane], 0u);
    }
    workgroupBarrier();
    if all(pixel < params.size) {
        let p = textureLoad(gbuffer_position, vec2<i32>(pixel), 0);
        if p.w != 0.0 {
            let d = max(distance(p.xyz, params.camera_position.xyz), 1e-30);
            let k = clamp(floor(log2(params.scene_sphere.w / d)), 0.0, 15.0);
            atomicAdd(&seen_here[u32(k)], 1u);
        }
    }
    workgroupBarrier();
    if lane < 16u {
        let count = atomicLoad(&seen_here[lane]);
        if count != 0u {
            atomicAdd(&seen[lane], count);
        }
    }
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    if params.seen_region != 0u {
        see(id.xy, lane);
    }
    if any(id.xy >= params.size) {
        return;
    }
    let pixel = id.y * params.size.x + id.x;
    let gp = textureLoad(gbuffer_position, vec2<i32>(id.xy), 0);
    var sample = vec3<f32>(0.0);
    var rng = pcg_hash(pixel ^ pcg_hash(params.sequence * 0x85ebca6bu + 0x27d4eb2fu));
    // Importons a rough-glass pixel leaves past its own slot, from `first_extra` on.
    var extras = 0u;
#ifdef IMPORTONS
    importons[pixel].triangle = NO_IMPORTON;
    var first_extra = 0u;
    shown_beyond = 0.0;
#endif
    if gp.w != 0.0 {
        let gn = textureLoad(gbuffer_normal, vec2<i32>(id.xy), 0);
        let m = gbuffer_material(gp, gn.w);
#ifdef TEXTURED
        surfaces[pixel] = resolve_surface(m, kernel_normal(gp, gn.xyz), gn.xyz);
#endif
        // Shaded where this iteration's point of the pixel (`shading_jitter`) meets the same
        // surface, else at the G-buffer's.
        var at = array<vec4<f32>, 2>(gp, gn);
        var lit = m;
#ifdef SHADING_POINTS
        if any(params.shading_jitter != vec2<f32>(0.0)) {
            let hit = camera_hit(params, vec2<f32>(id.xy) + 0.5 + params.shading_jitter);
            if same_surface(params, packed_surface(gp, gn.xyz, surface_marks(gp)), hit[0], hit[1], surface_marks(hit[0])) {
                at = hit;
                lit = gbuffer_material(hit[0], gn.w);
            }
        }
#endif
        let first = Vertex(at[0].xyz, at[1].xyz, lit, at[0].w > 0.0, gbuffer_triangle(at[0].w), toward_eye(params, at[0].xyz));
        var paths = 1u;
#ifdef IMPORTONS
        let rough_glass = glass_share(m) > 0.0 && m.perceptual_roughness >= DELTA_ROUGHNESS;
        paths = select(1u, SPLIT_PATHS, rough_glass && !stores_photons(m));
        if paths > 1u {
            let pixels = params.size.x * params.size.y;
            let room = arrayLength(&importons) - pixels;
            first_extra = atomicAdd(&importon_stats[2], SPLIT_IMPORTONS - 1u);
            extras = select(0u, SPLIT_IMPORTONS - 1u, first_extra + SPLIT_IMPORTONS - 1u <= room);
            first_extra += pixels;
        }
#endif
#ifdef EMITTERS
        emitter_draws = max(EMITTER_DRAWS / paths, 1u);
#endif
        for (var k = 0u; k < paths; k += 1u) {
            // Each path its own point of the pixel's sequence over iterations.
            stratified_draws(pixel, params.sequence * paths + k);
            var slot = select(NO_IMPORTON, pixel, k == 0u);
#ifdef IMPORTONS
            if k > 0u && k <= extras {
                slot = first_extra + k - 1u;
                importons[slot].triangle = NO_IMPORTON;
            }
#endif
            sample += camera_path(first, slot, 1.0 / f32(1u + extras), &rng);
        }
        sample /= f32(paths);
    }
#ifdef SKY
    else if params.indirect_only == 0u {
        // Nothing in this pixel: the sky.
        sample = params.sky.rgb;
    }
#endif
    // w: how far past its surface the pixel's glass or mirror shows (`shown_beyond`), as
    // -1 - that where a sphere light hides the surface (accumulate.wgsl tells them apart).
    var beyond = 0.0;
#ifdef IMPORTONS
    beyond = shown_beyond;
#endif
#ifdef SPHERE_LIGHTS_SEEN
    if params.indirect_only == 0u {
        let sphere = spheres_in_pixel(id.xy, gp);
        sample += sphere;
        beyond = select(beyond, -1.0 - beyond, any(sphere > vec3<f32>(0.0)));
    }
#endif
    samples[pixel] = vec4<f32>(sample, beyond);
#ifdef IMPORTONS
    importons[pixel].extras = extras;
    importons[pixel].first_extra = first_extra;
#endif
}
