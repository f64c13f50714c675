// A pixel's history under a camera move (accumulate.wgsl with HISTORY): what the pixel saw
// (its marker byte, as kept), what its glass or mirror shows, and where last frame's image
// held them.
#define_import_path bevy_rppm::reproject

#import bevy_rppm::common::{IterationParams, DELTA_ROUGHNESS}
#import bevy_rppm::camera::{camera_ray, toward_eye, previous_pixel}
#import bevy_rppm::scene::gbuffer_material
#import bevy_rppm::surface::{same_surface, mixed_surface}
#ifdef IMPORTONS
#import bevy_rppm::common::{Importon, NO_IMPORTON}
#endif

// Last frame's estimate and history, for reprojection.
@group(1) @binding(8) var<storage, read> previous_radiance: array<vec4<f32>>;
@group(1) @binding(9) var<storage, read> previous_history: array<vec4<f32>>;
#ifdef IMPORTONS
// This iteration's importons: where a pixel's camera path went on to.
@group(1) @binding(10) var<storage, read> importons: array<Importon>;
#endif

// Perceptual roughness under which a metal's or glass's direct light is what it shows of the
// lights and emitters: their small, bright images, which one jittered sample hits or misses.
const SPECULAR_ROUGHNESS: f32 = 0.5;

// What the surface at a G-buffer texel shows of the view (`view_shown`): the lights and the
// scene as the camera sees them (glass and glossy metal under SPECULAR_ROUGHNESS), and blurred
// (rough metal or frosted glass, not a mirror or clear glass: what it shows is fetched where
// its surface was, and holds while the view turns within its lobe).
const SHOWS_VIEW: u32 = 1u;
const SHOWS_BLURRED: u32 = 2u;
// A glossy dielectric under SPECULAR_ROUGHNESS (plastic): its direct light holds the lights'
// highlights, which move over it as the view turns; what it shows of the scene is its
// photons' (indirect light), kept as a diffuse surface's.
const SHOWS_GLOSS: u32 = 4u;

// `view_shown`'s bits, and the surface's perceptual roughness.
struct Shown {
    flags: u32,
    roughness: f32,
}

fn view_shown(position: vec4<f32>, footprint: f32) -> Shown {
    if position.w == 0.0 {
        return Shown(0u, 1.0);
    }
    let m = gbuffer_material(position, footprint);
    let r = m.perceptual_roughness;
    let rough = r >= DELTA_ROUGHNESS;
    if r >= SPECULAR_ROUGHNESS {
        return Shown(0u, r);
    }
    if !(m.metallic >= 0.5 || m.specular_transmission > 0.0) {
        return Shown(select(0u, SHOWS_GLOSS, rough), r);
    }
    return Shown(SHOWS_VIEW | select(0u, SHOWS_BLURRED, rough), r);
}

// Iterations of a rough metal's or frosted glass's history (a glossy dielectric's direct
// light) that still show this view under a camera move: what it reflects or lets through
// turns with the view, and its oldest sample kept must have seen it from within the lobe's
// width (GGX α, the roughness squared) of the view now.
fn lobe_iterations(params: IterationParams, position: vec4<f32>, roughness: f32) -> f32 {
    var then = params.previous_eye.xyz;
    if params.previous_eye.w != 0.0 {
        then = normalize(then - position.xyz);
    }
    let turn = acos(clamp(dot(toward_eye(params, position.xyz), then), -1.0, 1.0));
    return floor(roughness * roughness / max(turn, 1e-6));
}

// The point a pixel's glass or mirror shows (where its camera path went on to: its importon,
// `beyond` past the G-buffer point along the path), w its footprint there (0: none).
fn shown_point(params: IterationParams, position: vec4<f32>, normal: vec4<f32>, index: u32, beyond: f32) -> vec4<f32> {
#ifdef IMPORTONS
    let importon = importons[index];
    if position.w == 0.0 || beyond <= 0.0 || importon.triangle == NO_IMPORTON {
        return vec4<f32>(0.0);
    }
    let near = distance(params.camera_position.xyz, position.xyz);
    let footprint = select(normal.w * (near + beyond) / max(near, 1e-30), normal.w, params.orthographic != 0u);
    return vec4<f32>(importon.position, footprint);
#else
    return vec4<f32>(0.0);
#endif
}

// Where in last frame's image this pixel's glass or mirror showed the point it shows now
// (`shown`; z: 1 if found): what they show moves with that point, not with their surface.
// Looked for around the point's image in a mirror (unfolded along the camera ray, `beyond`
// past the surface; near it through flat water): the pixel whose point lay nearest, offset
// as the unfolded image is from its pixel.
fn previous_shown(params: IterationParams, position: vec4<f32>, shown: vec4<f32>, beyond: f32) -> vec3<f32> {
    let unfolded = position.xyz - toward_eye(params, position.xyz) * beyond;
    let centre = previous_pixel(params, vec4<f32>(unfolded, 1.0));
    if shown.w == 0.0 || centre.z == 0.0 {
        return vec3<f32>(0.0);
    }
    let at = vec2<i32>(floor(centre.xy));
    var best = vec2<i32>(-1);
    var nearest = 1e30;
    for (var k = 0; k < (2 * SHOWN_SEARCH + 1) * (2 * SHOWN_SEARCH + 1); k += 1) {
        let p = at + vec2<i32>(k % (2 * SHOWN_SEARCH + 1), k / (2 * SHOWN_SEARCH + 1)) - SHOWN_SEARCH;
        let kept = previous_shown_point(params, p);
        let d = distance(kept.xyz, shown.xyz);
        if shows_same(kept, shown) && d <= nearest {
            nearest = d;
            best = p;
        }
    }
    if best.x < 0 {
        return vec3<f32>(0.0);
    }
    return vec3<f32>(vec2<f32>(best) + 0.5 + subpixel(params, best, shown.xyz), 1.0);
}

// Where between pixel `p` and its neighbours last frame's shown point would be `x`: one
// Gauss-Newton step on the points' differences across the pixels (within a pixel each way),
// so that a history moved less than a pixel a frame does not stay behind.
fn subpixel(params: IterationParams, p: vec2<i32>, x: vec3<f32>) -> vec2<f32> {
    let here = previous_shown_point(params, p);
    var axes: array<vec3<f32>, 2>;
    for (var a = 0; a < 2; a += 1) {
        let step = vec2<i32>(1 - a, a);
        let after = previous_shown_point(params, p + step);
        let before = previous_shown_point(params, p - step);
        let ahead = select(here.xyz, after.xyz, after.w > 0.0);
        let behind = select(here.xyz, before.xyz, before.w > 0.0);
        let span = select(0.0, 1.0, after.w > 0.0) + select(0.0, 1.0, before.w > 0.0);
        axes[a] = select(vec3<f32>(0.0), (ahead - behind) / max(span, 1.0), span > 0.0);
    }
    let gx = axes[0];
    let gy = axes[1];
    let r = x - here.xyz;
    let a = vec3<f32>(dot(gx, gx), dot(gx, gy), dot(gy, gy));
    let det = a.x * a.z - a.y * a.y;
    if det <= 1e-12 * (a.x + a.z) * (a.x + a.z) {
        return vec2<f32>(0.0);
    }
    let b = vec2<f32>(dot(gx, r), dot(gy, r));
    return clamp(vec2<f32>(a.z * b.x - a.y * b.y, a.x * b.y - a.y * b.x) / det, vec2<f32>(-1.0), vec2<f32>(1.0));
}

// Last frame's shown point at pixel `p` (none outside the image).
fn previous_shown_point(params: IterationParams, p: vec2<i32>) -> vec4<f32> {
#ifdef IMPORTONS
    if any(p < vec2<i32>(0)) || any(p >= vec2<i32>(params.size)) {
        return vec4<f32>(0.0);
    }
    return previous_history[3u * params.size.x * params.size.y + u32(p.y) * params.size.x + u32(p.x)];
#else
    return vec4<f32>(0.0);
#endif
}

// How far (pixels) around a shown point's unfolded image its last pixel is looked for, and
// how near (footprints) its point must have been.
const SHOWN_SEARCH: i32 = 2;
const SHOWN_MATCH: f32 = 2.0;

// Whether last frame's shown point `kept` is the point `shown` is now.
fn shows_same(kept: vec4<f32>, shown: vec4<f32>) -> bool {
    return kept.w > 0.0 && distance(kept.xyz, shown.xyz) <= SHOWN_MATCH * shown.w;
}

// Last frame's estimate, direct light and surface where this pixel's point was (and, where
// textures vary, the albedo its direct light was demodulated by).
struct Reprojected {
    radiance: vec4<f32>,
    direct: vec4<f32>,
    surface: vec4<f32>,
    found: bool,
    albedo: vec3<f32>,
}

#ifdef DEMODULATED
// The history block of a pixel's albedo: after the points glass and mirrors show.
fn albedo_block() -> u32 {
#ifdef IMPORTONS
    return 4u;
#else
    return 3u;
#endif
}
#endif

// Catmull-Rom weights of the four taps around a point `t` past the second (0..1).
fn catmull_rom(t: f32) -> vec4<f32> {
    let t2 = t * t;
    let t3 = t2 * t;
    return vec4<f32>(-0.5 * t3 + t2 - 0.5 * t, 1.5 * t3 - 2.5 * t2 + 1.0, -1.5 * t3 + 2.0 * t2 + 0.5 * t, 0.5 * t3 - 0.5 * t2);
}

// This pixel's history under a camera move: last frame's at the point's position, of the
// pixels around it that saw this surface (or, through glass and mirrors, `shown`) and no
// other. Taken from the nearest pixel, a history stays put while the image moves less than
// half a pixel a frame, and drags; bilinearly, it blurs a little more each frame. So the
// 4 × 4 pixels around it weigh in by Catmull-Rom, bounded by the four nearest (which alone
// weigh in, bilinearly, where any of the 16 saw something else).
fn reproject(params: IterationParams, position: vec4<f32>, normal: vec4<f32>, marks: u32, shown: Shown, shown_here: vec4<f32>, beyond: f32, pixel: vec2<u32>) -> Reprojected {
    var point = vec4<f32>(position.xyz, 1.0);
    if position.w == 0.0 {
        point = vec4<f32>(camera_ray(params, pixel).direction, 0.0);
    }
    var at = previous_pixel(params, point);
    var through = false;
    if (shown.flags & SHOWS_VIEW) != 0u && (shown.flags & SHOWS_BLURRED) == 0u {
        let seen = previous_shown(params, position, shown_here, beyond);
        through = seen.z != 0.0;
        at = select(at, seen, through);
    }
    var r = Reprojected(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0), false, vec3<f32>(0.0));
    if at.z == 0.0 {
        return r;
    }
    let pixels = params.size.x * params.size.y;
    // Last frame's samples lay `jitter` before their pixels' centres, as this one's do (a
    // camera move restarts the jitter): a history read at the centres would move by as much
    // each frame. (A shown point's pixel was found among those samples.)
    let corner = at.xy + select(params.jitter, vec2<f32>(0.0), through) - 0.5;
    let base = vec2<i32>(floor(corner)) - 1;
    let f = corner - floor(corner);
    let wx = catmull_rom(f.x);
    let wy = catmull_rom(f.y);
    // Which of the 16 taps saw this pixel's surface.
    var seen = 0u;
    for (var k = 0; k < 16; k += 1) {
        let p = base + vec2<i32>(k & 3, k >> 2u);
        if any(p < vec2<i32>(0)) || any(p >= vec2<i32>(params.size)) {
            continue;
        }
        let source = u32(p.y) * params.size.x + u32(p.x);
        let surface = previous_history[source];
        var same = same_surface(params, surface, position, normal, marks);
        if through {
            same = shows_same(previous_shown_point(params, p), shown_here);
        }
        seen |= select(0u, 1u << u32(k), same && !mixed_surface(surface));
    }
    let sharp = seen == 0xffffu;
    var total = 0.0;
    var most = 0.0;
    var lo = vec3<f32>(1e30);
    var hi = vec3<f32>(-1e30);
    var lo_direct = vec3<f32>(1e30);
    var hi_direct = vec3<f32>(-1e30);
    var radiance = vec3<f32>(0.0);
    var direct = vec3<f32>(0.0);
    var albedo = vec3<f32>(0.0);
    var lo_albedo = vec3<f32>(1e30);
    var hi_albedo = vec3<f32>(-1e30);
    for (var k = 0; k < 16; k += 1) {
        let tap = vec2<i32>(k & 3, k >> 2u);
        let inner = all(tap >= vec2<i32>(1)) && all(tap <= vec2<i32>(2));
        if (seen & (1u << u32(k))) == 0u || !(sharp || inner) {
            continue;
        }
        let p = base + tap;
        let source = u32(p.y) * params.size.x + u32(p.x);
        let kept = previous_radiance[source];
        let kept_direct = previous_history[pixels + source];
        var kept_albedo = vec3<f32>(0.0);
#ifdef DEMODULATED
        kept_albedo = previous_history[albedo_block() * pixels + source].rgb;
#endif
        if inner {
            let w = mix(1.0 - f.x, f.x, f32(tap.x - 1)) * mix(1.0 - f.y, f.y, f32(tap.y - 1)) + 1e-6;
            r.radiance += w * kept;
            r.direct += w * kept_direct;
            r.albedo += w * kept_albedo;
            total += w;
            lo = min(lo, kept.rgb);
            hi = max(hi, kept.rgb);
            lo_direct = min(lo_direct, kept_direct.rgb);
            hi_direct = max(hi_direct, kept_direct.rgb);
            lo_albedo = min(lo_albedo, kept_albedo);
            hi_albedo = max(hi_albedo, kept_albedo);
            if w > most {
                most = w;
                r.surface = previous_history[source];
            }
        }
        let sharp_weight = wx[tap.x] * wy[tap.y];
        radiance += sharp_weight * kept.rgb;
        direct += sharp_weight * kept_direct.rgb;
        albedo += sharp_weight * kept_albedo;
    }
    if total > 0.0 {
        r.radiance /= total;
        r.direct /= total;
        r.albedo /= total;
        r.found = true;
    }
    if sharp {
        r.radiance = vec4<f32>(clamp(radiance, lo, hi), r.radiance.w);
        r.direct = vec4<f32>(clamp(direct, lo_direct, hi_direct), r.direct.w);
        r.albedo = clamp(albedo, lo_albedo, hi_albedo);
    }
    return r;
}
