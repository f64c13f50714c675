// The progressive estimate: this iteration's local illumination plus its splatted photons
// (directly on the G-buffer, and through importons), averaged into the radiance of all
// iterations since the last reset (w: the pixel's count), or with HISTORY of the pixel's
// history kept through motion.
#import bevy_rppm::common::{IterationParams, subsample_representative}
#import bevy_rppm::camera::{camera_ray, toward_eye}
#ifdef SUBSAMPLED
#import bevy_rppm::bsdf::{bsdf_from, bsdf_gathered}
#import bevy_rppm::scene::gbuffer_material
#else
#ifdef DEMODULATED
#import bevy_rppm::scene::gbuffer_material
#endif
#endif
#ifdef DEMODULATED
#import bevy_rppm::scene::{material_at, triangle_at, barycentrics, as_seen_from, gbuffer_triangle}
#import bevy_rppm::camera::camera_ray_at
#import bevy_rppm::bsdf::diffuse_color
#import bevy_rppm::microfacet::specular_f0
#import bevy_rppm::common::{Material, MATERIAL_ALPHA_MASK}
#import bevy_rppm::reproject::albedo_block
#endif
#ifdef HISTORY
#import bevy_rppm::reproject::{previous_history, view_shown, lobe_iterations, shown_point, reproject, Shown, SHOWS_VIEW, SHOWS_BLURRED, SHOWS_GLOSS}
#import bevy_rppm::surface::{neighbour, surface_marks, emitting, packed_surface, mixed_surface, moved_surface, same_surface, KEPT, KEPT_EMITTING, KEPT_MOVING, KEPT_MIXED}
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
// Per pixel, in four blocks of one vec4 a pixel: the surface it saw, the running mean of its
// direct light (local illumination; w its count), the mean of its indirect samples since the
// last change (w their count), and the point its glass or mirror showed (`shown_point`).
// `radiance` holds the total: direct plus indirect (w the indirect count). Last frame's copies
// are bound in reproject.wgsl.
@group(1) @binding(7) var<storage, read_write> history: array<vec4<f32>>;

// HistoryFlags (src/view/params.rs).
const REPROJECT: u32 = 1u;
const CHECK_SURFACE: u32 = 2u;
const CHECK_LIGHT: u32 = 4u;
const NEW_DIRECT: u32 = 8u;
const RELIT: u32 = 16u;

// The marker byte of what a pixel sees: its surface's, emitting where a sphere light hides
// it (`samples`' w below 0: eye_paths.wgsl), as its history is the light's, not the surface's.
fn pixel_marks(pixel: vec2<i32>) -> u32 {
    let marks = surface_marks(textureLoad(gbuffer_position, pixel, 0));
    let sphere = samples[u32(pixel.y) * params.size.x + u32(pixel.x)].w < 0.0;
    return marks | select(0u, KEPT | KEPT_EMITTING, sphere);
}

// How far past its surface a pixel's glass or mirror shows (`samples`' w).
fn shown_beyond(w: f32) -> f32 {
    return select(w, -1.0 - w, w < 0.0);
}

// Whether this pixel or one of its eight neighbours sees an emissive surface (EMITTERS: the
// scene has one): light whose direct part is mostly its emission, which a change elsewhere
// in the scene leaves alone.
fn emitter_nearby(pixel: vec2<u32>) -> bool {
    var found = false;
#ifdef EMITTERS
    for (var k = 0; k < 9; k += 1) {
        found = found || emitting(pixel_marks(neighbour(params.size, pixel, k)));
    }
#endif
    return found;
}

// Whether this pixel or one of its eight neighbours sees the kept surface now.
fn surface_nearby(kept: vec4<f32>, pixel: vec2<u32>) -> bool {
    var found = false;
    for (var k = 0; k < 9; k += 1) {
        let p = neighbour(params.size, pixel, k);
        let position = textureLoad(gbuffer_position, p, 0);
        let normal = textureLoad(gbuffer_normal, p, 0);
        found = found || same_surface(params, kept, position, normal, pixel_marks(p));
    }
    return found;
}

// The neighbourhood of each pixel whose samples bound its history while a scene change
// settles: (2 RADIUS + 1)² pixels, read from a workgroup tile of this iteration's direct
// light ([0]) and indirect light ([1]), and each pixel's mean indirect light since the last
// change ([2]: the bound tightens as that mean converges).
const RADIUS: u32 = 2u;
const TILE: u32 = 8u + 2u * RADIUS;
var<workgroup> tile: array<array<vec3<f32>, 3>, TILE * TILE>;

// Width of the box history is clamped to, in standard deviations of the neighbourhood's
// samples (variance clipping, Salvi 2016): light that left or came is clamped to this
// iteration's, while noise, which spreads the neighbourhood as much, passes.
const GAMMA: f32 = 1.0;
// Its width for indirect light when the light changed.
const RELIT_GAMMA: f32 = 2.0;

// Direct samples a still silhouette's pixel keeps while the light changes (`relit_edge`).
const EDGE_SAMPLES: f32 = 3.0;

// Direct samples a pixel keeps through a camera move where direct light is exact at each
// sample's point (EXACT_DIRECT): what its history adds there is the jitter's anti-aliasing
// of edges and textures, which each frame's reprojection (a resampling) blurs a little more.
// (Sampled lights — sphere lights, emitters, a sky — need the window for their noise.)
const MOVING_DIRECT_SAMPLES: f32 = 3.0;

#ifdef DEMODULATED
// What textures scale a surface's light by: its diffuse colour plus its specular F0 (1
// where the pixel sees nothing).
fn albedo(m: Material) -> vec3<f32> {
    return diffuse_color(m) + specular_f0(m);
}

fn sample_albedo(position: vec4<f32>, footprint: f32) -> vec3<f32> {
    if position.w == 0.0 {
        return vec3<f32>(1.0);
    }
    return albedo(gbuffer_material(position, footprint));
}

// The albedo over a pixel's footprint, as a converged image's jittered samples average it:
// the surface's plane (the G-buffer's triangle's) met by the rays through the centres of
// the pixel's four quarters, but where a cut-out leaves a hole (`sample`, this iteration's
// albedo, where all four do).
fn footprint_albedo(pixel: vec2<u32>, position: vec4<f32>, footprint: f32, sample: vec3<f32>) -> vec3<f32> {
    let triangle = gbuffer_triangle(position.w);
    let t = triangle_at(triangle);
    let n = cross(t.position_b - t.position_a, t.position_c - t.position_a);
    var sum = vec3<f32>(0.0);
    var taps = 0.0;
    for (var k = 0u; k < 4u; k += 1u) {
        // The pixel's centre is `jitter` past its sample's, which the view's centre is.
        let at = vec2<f32>(pixel) + 0.5 + params.jitter + (vec2<f32>(f32(k & 1u), f32(k >> 1u)) - 0.5) * 0.5;
        let ray = camera_ray_at(params, at);
        let along = dot(ray.direction, n);
        let x = select(position.xyz, ray.origin + ray.direction * (dot(position.xyz - ray.origin, n) / along), abs(along) > 1e-6 * length(n));
        let m = as_seen_from(material_at(triangle, barycentrics(t, x), 0.5 * footprint), position.w > 0.0);
        let hole = (m.flags & MATERIAL_ALPHA_MASK) != 0u && m.base_color.a < m.alpha_cutoff;
        sum += select(albedo(m), vec3<f32>(0.0), hole);
        taps += select(1.0, 0.0, hole);
    }
    return select(sample, sum / taps, taps > 0.0);
}

// What turns light on a texture of mean albedo `kept` into light on one of albedo `now`.
fn texture_ratio(now: vec3<f32>, kept: vec3<f32>) -> vec3<f32> {
    return select(vec3<f32>(1.0), now / kept, kept > vec3<f32>(0.0));
}
#endif

// Fills the tile around workgroup `group` with direct and indirect samples (pixels outside
// the image repeat its edge).
fn fill_tile(group: vec2<u32>, thread: u32) {
    let origin = vec2<i32>(group * 8u) - i32(RADIUS);
    for (var k = thread; k < TILE * TILE; k += 64u) {
        let at = origin + vec2<i32>(i32(k % TILE), i32(k / TILE));
        let pixel = vec2<u32>(clamp(at, vec2<i32>(0), vec2<i32>(params.size) - 1));
        let index = pixel.y * params.size.x + pixel.x;
        let direct = samples[index].rgb;
        let indirect = iteration_sample(pixel) - direct;
        // A neighbour's mean from last iteration's copy: its own pixel's write would race.
        let kept = previous_history[2u * params.size.x * params.size.y + index];
        tile[k] = array<vec3<f32>, 3>(direct, indirect, fresh_after(kept, indirect).rgb);
    }
}

// A pixel's mean indirect light since the last change (`kept`, w: its count) with this
// iteration's `indirect` sample.
fn fresh_after(kept: vec4<f32>, indirect: vec3<f32>) -> vec4<f32> {
    let restart = params.iteration == 0u || (params.history_flags & CHECK_SURFACE) != 0u;
    let fresh = select(kept, vec4<f32>(0.0), restart);
    return vec4<f32>(fresh.rgb + (indirect - fresh.rgb) / (fresh.w + 1.0), fresh.w + 1.0);
}

fn tile_index(local: vec2<u32>) -> u32 {
    return (local.y + RADIUS) * TILE + local.x + RADIUS;
}

// Direct (part 0) history clamped to mean ± `gamma` σ of the neighbourhood's samples of it,
// per channel, or indirect history (2) to that of the neighbourhood's means since the last
// change: one iteration's photon noise comes in blotches wider than the neighbourhood, which
// the means lose as they converge, so a change's ghost is cut closer every iteration.
fn clamped(history: vec3<f32>, local: vec2<u32>, part: u32, gamma: f32) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    var squares = vec3<f32>(0.0);
    for (var y = 0u; y <= 2u * RADIUS; y += 1u) {
        for (var x = 0u; x <= 2u * RADIUS; x += 1u) {
            let sample = tile[(local.y + y) * TILE + local.x + x][part];
            sum += sample;
            squares += sample * sample;
        }
    }
    let n = f32((2u * RADIUS + 1u) * (2u * RADIUS + 1u));
    let mean = sum / n;
    let spread = gamma * sqrt(max(squares / n - mean * mean, vec3<f32>(0.0)));
    var lo = mean - spread;
    var hi = mean + spread;
    if part == 0u {
        // Direct light, nearly noiseless, is right where the pixel's own sample is: a pixel
        // beside brighter ones (a dark object's rim) is not pulled towards them.
        let own = tile[tile_index(local)][0];
        lo = min(lo, own);
        hi = max(hi, own);
    }
    return clamp(history, lo, hi);
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

// This iteration's sample of a pixel: its local light plus its splatted photons.
fn iteration_sample(pixel: vec2<u32>) -> vec3<f32> {
    let index = pixel.y * params.size.x + pixel.x;
    var sample = samples[index].rgb;
#ifdef SUBSAMPLED
    let gp = textureLoad(gbuffer_position, vec2<i32>(pixel), 0);
    if gp.w != 0.0 {
        let gn = textureLoad(gbuffer_normal, vec2<i32>(pixel), 0);
        let m = gbuffer_material(gp, gn.w);
        let wo = toward_eye(params, gp.xyz);
        let light = upsampled_light(pixel, gp.xyz, gn.xyz, gn.w);
        sample += bsdf_gathered(m, bsdf_from(m, gn.xyz, wo), gn.xyz, wo, gn.xyz) * light;
    }
#else
    sample += textureLoad(splats, vec2<i32>(pixel), 0).rgb;
#endif
#ifdef IMPORTONS
    sample += importon_radiance[index].rgb;
#endif
    return sample;
}

@compute @workgroup_size(8, 8, 1)
fn main(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_id) local: vec3<u32>,
    @builtin(local_invocation_index) thread: u32,
    @builtin(workgroup_id) group: vec3<u32>,
) {
#ifdef HISTORY
    let settling = (params.history_flags & CHECK_LIGHT) != 0u;
    // A camera move's first iteration clamps what it reprojected onto glass and mirrors.
    let reprojecting = (params.history_flags & REPROJECT) != 0u;
    let clamping = settling || reprojecting;
    if clamping {
        fill_tile(group.xy, thread);
    }
    workgroupBarrier();
#endif
    if any(id.xy >= params.size) {
        return;
    }
    let index = id.y * params.size.x + id.x;
#ifdef HISTORY
    // While clamping the tile holds this pixel's indirect sample already.
    var sample: vec3<f32>;
    if clamping {
        sample = samples[index].rgb + tile[tile_index(local.xy)][1];
    } else {
        sample = iteration_sample(id.xy);
    }
#else
    let sample = iteration_sample(id.xy);
#endif
    var kept = select(radiance[index], vec4<f32>(0.0), params.iteration == 0u);
    // The iteration's weight in the estimate, whose w is the weights' sum: a probing
    // iteration's fewer photons are that much noisier (`photon_weight`).
    let weight = params.photon_weight;
#ifdef HISTORY
    let pixels = params.size.x * params.size.y;
    let position = textureLoad(gbuffer_position, vec2<i32>(id.xy), 0);
    let normal = textureLoad(gbuffer_normal, vec2<i32>(id.xy), 0);
    var kept_direct = select(history[pixels + index], vec4<f32>(0.0), params.iteration == 0u);
    // The surface this pixel's last sample saw (where it was, under a camera move).
    var kept_surface = history[index];
    var kept_albedo = vec3<f32>(0.0);
#ifdef DEMODULATED
    kept_albedo = history[albedo_block() * pixels + index].rgb;
#endif
    let marks = pixel_marks(vec2<i32>(id.xy));
    var shown = Shown(0u, 1.0);
    if clamping {
        shown = view_shown(position, normal.w);
    }
    let checking = (params.history_flags & CHECK_SURFACE) != 0u && params.iteration != 0u;
    let beyond = shown_beyond(samples[index].w);
    let shown_here = shown_point(params, position, normal, index, beyond);
    // Whether this pixel sees the surface its history saw last (or what it showed).
    var same: bool;
    if checking && reprojecting {
        let r = reproject(params, position, normal, marks, shown, shown_here, beyond, id.xy);
        kept = r.radiance;
        kept_direct = r.direct;
        kept_surface = r.surface;
        kept_albedo = r.albedo;
        same = r.found;
    } else {
        same = same_surface(params, kept_surface, position, normal, marks);
    }
    if checking {
        // A still camera's jitter moves a pixel's samples across an edge, where a neighbour
        // that sees the kept surface keeps the pixel's history (its coverage). Under a
        // camera move each frame starts the jitter again: the pixel's own test, and a history
        // of several surfaces (a silhouette's pixel, a frame's samples on both sides) is
        // dropped, as it would carry one's light onto the other as the silhouette moves.
        // Rough metal and frosted glass keep their history while the view turns within their
        // lobe; a glossy dielectric, its direct light (its highlights).
        var kept_here: bool;
        if reprojecting {
            kept_here = same;
            if (shown.flags & (SHOWS_BLURRED | SHOWS_GLOSS)) != 0u {
                let lobe = lobe_iterations(params, position, shown.roughness);
                kept_direct.w = min(kept_direct.w, lobe);
                if (shown.flags & SHOWS_BLURRED) != 0u {
                    kept_here = kept_here && lobe >= 1.0;
                    kept.w = min(kept.w, lobe);
                }
            }
        } else {
            kept_here = surface_nearby(kept_surface, id.xy);
        }
        if !kept_here {
            kept = vec4<f32>(0.0);
            kept_direct = vec4<f32>(0.0);
        }
    }
    // Direct light (this iteration's local sample) and indirect light (its splats) are kept
    // apart, each a running mean of at most the window while a change settles. After a scene
    // change, indirect light is clamped to what this iteration's neighbourhood saw of it, so
    // a caustic that moved does not linger where it was, and direct light, traced anew each
    // iteration with little noise, starts again, so shadows follow at once; but next to an
    // emitter, and on glass and glossy metal, it is clamped too: one jittered sample of a
    // bright rim, or of a light's small image in a mirror, is far noisier than the history.
    let direct_sample = samples[index].rgb;
    let indirect_sample = sample - direct_sample;
    var indirect = select(kept.rgb - kept_direct.rgb, vec3<f32>(0.0), kept.w == 0.0);
    var direct = select(kept_direct.rgb, vec3<f32>(0.0), kept_direct.w == 0.0);
    let near_emitter = settling && emitter_nearby(id.xy);
    // Glass and mirrors show the scene as the camera sees it, sharp: what a camera move
    // reprojects there is clamped, both parts (one sample of them is too noisy to start from).
    let view_dependent = (shown.flags & SHOWS_VIEW) != 0u;
    let bright_edges = near_emitter || view_dependent;
    let relit = (params.history_flags & RELIT) != 0u;
    if settling || view_dependent {
        // A light that moved changes indirect light everywhere and smoothly, which its
        // history follows within the window; a wider box lets more of it through. Not on
        // glass and mirrors, whose light moves with it sharply.
        indirect = clamped(indirect, local.xy, 2u, select(GAMMA, RELIT_GAMMA, relit && !view_dependent));
    }
    // When only objects moved (no light, emitter or material changed), a still surface's
    // direct light changes only where their shadows move: it keeps its history within what
    // its neighbourhood sees now, so its edges and textures keep averaging what their jitter
    // sees. A moving object's pixels, and those it left, start again.
    let still_surface = (marks & KEPT_MOVING) == 0u && !moved_surface(kept_surface);
    let still = settling && (params.history_flags & NEW_DIRECT) != 0u && !relit && still_surface;
    // When the light changed, a still silhouette's pixel (its history saw more than one
    // surface: the jitter crosses it) keeps a few samples, clamped: one a frame would show it
    // all lit or all dark, and a shadow moving over it lags little.
    let relit_edge = settling && relit && still_surface && mixed_surface(kept_surface) && !bright_edges;
    // A glossy dielectric's highlights move under a camera move: its direct history is
    // clamped to what this iteration's neighbourhood sees too.
    let moving_gloss = reprojecting && (shown.flags & SHOWS_GLOSS) != 0u;
    if bright_edges || still || relit_edge || moving_gloss {
        direct = clamped(direct, local.xy, 0u, GAMMA);
    } else if (params.history_flags & NEW_DIRECT) != 0u {
        kept_direct.w = 0.0;
        direct = vec3<f32>(0.0);
    }
    if relit_edge {
        kept_direct.w = min(kept_direct.w, EDGE_SAMPLES);
    }
#ifdef EXACT_DIRECT
    // Not on glass and mirrors: one sample of a light's image there is noisy.
    if reprojecting && checking && !view_dependent {
        kept_direct.w = min(kept_direct.w, MOVING_DIRECT_SAMPLES);
    }
#endif
    kept.w = min(kept.w, f32(params.history_cap));
    // An emitter's rim keeps all its samples: a window of them would leave the rim's
    // coverage as noisy as the window is short, and the clamp bounds what a change leaves.
    kept_direct.w = select(min(kept_direct.w, f32(params.history_cap)), kept_direct.w, near_emitter);
    indirect += (indirect_sample - indirect) * weight / (kept.w + weight);
    direct += (direct_sample - direct) / (kept_direct.w + 1.0);
#ifdef DEMODULATED
    // The mean albedo of the direct light's samples (`kept_a`). Each frame's reprojection
    // blurs the textures in a pixel's history a little, and a window of them a lot; so under
    // a camera move the light (each part a mean of albedo × light) is kept, and the albedo
    // it shows is the pixel's footprint's now: sharp, and anti-aliased. Not on an emitter,
    // whose emission its albedo does not scale.
    let a = sample_albedo(position, normal.w);
    var kept_a = kept_albedo + (a - kept_albedo) / (kept_direct.w + 1.0);
    if reprojecting && checking && !view_dependent && !emitting(marks) && position.w != 0.0 {
        let area = footprint_albedo(id.xy, position, normal.w, a);
        direct *= texture_ratio(area, kept_a);
        indirect *= texture_ratio(area, kept_albedo + (a - kept_albedo) * weight / (kept.w + weight));
        kept_a = area;
    }
    history[albedo_block() * pixels + index] = vec4<f32>(kept_a, 0.0);
#endif
    // Samples of another surface than the last one's mix the history (jitter across an edge).
    let held = kept.w > 0.0;
    let mixed = held && (mixed_surface(kept_surface) || !same);
    history[index] = packed_surface(position, normal.xyz, marks | select(0u, KEPT_MIXED, mixed));
    history[pixels + index] = vec4<f32>(direct, kept_direct.w + 1.0);
    history[2u * pixels + index] = fresh_after(history[2u * pixels + index], indirect_sample);
#ifdef IMPORTONS
    history[3u * pixels + index] = shown_here;
#endif
    radiance[index] = vec4<f32>(direct + indirect, kept.w + weight);
#else
    radiance[index] = vec4<f32>(kept.rgb + (sample - kept.rgb) * weight / (kept.w + weight), kept.w + weight);
#endif
}
