// Outliers: a camera path's rare sample (its local light plus the photons its importon
// gathered) far above what its pixel's neighbourhood and its surface read so far (a small
// bright light met through rough glass: 10³ where the pixel reads 1) keeps BOUND·√k times
// that level (k: the pixel's iterations) and spreads the rest over the pixels of its surface
// around it (within 4 pixels, or as far as keeps each of them within its own bound, up to 16;
// over every surface around where its own is too thin), in proportion to their estimates.
// The image keeps its energy and the rare light lands near where it falls on average; as the
// bound grows with k, ever fewer samples are spread.
// What the camera sees of an emitter or a sphere light is never spread. The first iteration,
// which has no estimate, weighs its samples against their neighbours' (`level`).
#import bevy_rppm::common::{IterationParams, luminance}
#import bevy_rppm::scene::{front_emitting, gbuffer_triangle, triangles}

@group(1) @binding(0) var<uniform> params: IterationParams;
@group(1) @binding(1) var<storage, read_write> samples: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read> radiance: array<vec4<f32>>;
// Per pixel: the light it spreads (`bound`).
@group(1) @binding(3) var<storage, read_write> excess: array<vec4<f32>>;
@group(1) @binding(4) var gbuffer_position: texture_2d<f32>;
@group(1) @binding(5) var gbuffer_normal: texture_2d<f32>;
// Photons gathered by this iteration's importons, per pixel: a path's weight through rough
// glass brings its outliers too.
@group(1) @binding(6) var<storage, read_write> importon_radiance: array<vec4<f32>>;

// Pixels each side over which a sample spreads, and the most: a sample that would lift its
// surface's pixels within RADIUS past their own bound spreads farther.
const RADIUS: i32 = 4;
const MOST_RADIUS: i32 = 16;
// A sample may read this many times its level, times √k.
const BOUND: f32 = 4.0;

// A pixel's camera-path sample of this iteration.
fn path_sample(index: u32) -> vec3<f32> {
    return samples[index].rgb + importon_radiance[index].rgb;
}

// A pixel's estimate so far (luminance). The first iteration has none: the least sample
// among the pixel and its eight neighbours stands in, which a rare path's sample (or two
// side by side) does not lift, so what is spread goes where the light is, not to them.
// `bound` keeps it in `importon_radiance`'s w for `spread`, whose writes would change it.
fn level(pixel: vec2<i32>) -> f32 {
    if params.iteration != 0u {
        return luminance(radiance[pixel_index(pixel)].rgb);
    }
    let w = window(pixel, 1);
    var least = 3.4e38;
    for (var row = w.lo.y; row <= w.hi.y; row += 1) {
        for (var column = w.lo.x; column <= w.hi.x; column += 1) {
            least = min(least, luminance(path_sample(pixel_index(vec2<i32>(column, row)))));
        }
    }
    return least;
}

// How much of what pixel a spreads pixel b (`offset` from it) takes, before b's level: 0
// unless they see one surface (normals within ~25°, each point within a few footprints of
// the other's tangent plane; any surface where `any_surface`), falling off to 0 at `radius`
// + 1 so that no square shows. Symmetric, so what one gives the other takes.
fn kinship(a: vec4<f32>, a_normal: vec4<f32>, b: vec4<f32>, b_normal: vec4<f32>, offset: vec2<i32>, radius: i32, any_surface: bool) -> f32 {
    let d = b.xyz - a.xyz;
    let steps2 = f32(dot(offset, offset));
    let slack = (1.0 + sqrt(steps2)) * max(a_normal.w, b_normal.w);
    let off_plane = max(abs(dot(d, a_normal.xyz)), abs(dot(d, b_normal.xyz)));
    let same = b.w != 0.0 && (any_surface || (dot(a_normal.xyz, b_normal.xyz) > 0.9 && off_plane <= slack));
    let falloff = 1.0 - steps2 / f32((radius + 1) * (radius + 1));
    return select(0.0, falloff, same && falloff > 0.0);
}

// The highest estimate among a pixel and its eight neighbours: a feature smaller than a
// pixel (a light's highlight on a metal ball) is hit by some jittered samples and not others,
// a spread that is its own (nothing of it is spread). In the first iteration, the highest
// of the neighbours' samples (the pixel's own is the one weighed).
fn nearby_level(pixel: vec2<i32>) -> f32 {
    let w = window(pixel, 1);
    var highest = 0.0;
    for (var row = w.lo.y; row <= w.hi.y; row += 1) {
        for (var column = w.lo.x; column <= w.hi.x; column += 1) {
            let q = vec2<i32>(column, row);
            if params.iteration != 0u {
                highest = max(highest, level(q));
            } else if any(q != pixel) {
                highest = max(highest, luminance(path_sample(pixel_index(q))));
            }
        }
    }
    return highest;
}

struct Window {
    lo: vec2<i32>,
    hi: vec2<i32>,
}

// The pixels within `radius` of `pixel` (a square), inside the image.
fn window(pixel: vec2<i32>, radius: i32) -> Window {
    let last = vec2<i32>(params.size) - 1;
    return Window(max(pixel - radius, vec2<i32>(0)), min(pixel + radius, last));
}

fn pixel_index(p: vec2<i32>) -> u32 {
    return u32(p.y) * params.size.x + u32(p.x);
}

// Bounds this pixel's sample; what is above the bound goes to `excess`: its share per unit
// of receiver weight, and (w) the weights' sum.
@compute @workgroup_size(8, 8, 1)
fn bound(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= params.size) {
        return;
    }
    let pixel = vec2<i32>(id.xy);
    let index = pixel_index(pixel);
    excess[index] = vec4<f32>(0.0);
    if params.iteration == 0u {
        importon_radiance[index].w = level(pixel);
    }
    // Only a still estimate bounds a sample (the first iteration's by its neighbours'
    // samples, as one more): while a change settles (`Reuse`'s capped history) it is of the
    // light before, against which what the change lit would read as outliers.
    let at = textureLoad(gbuffer_position, pixel, 0);
    if at.w == 0.0 || params.history_cap != 0xffffffffu {
        return;
    }
    // An emitter's face or a sphere light seen by the camera is where it is, however few
    // jittered samples meet it (a sliver of it at an image's edge): none of it is spread.
    if front_emitting(triangles[gbuffer_triangle(at.w)].material, at.w) || samples[index].w < 0.0 {
        return;
    }
    let count = select(radiance[index].w, 1.0, params.iteration == 0u);
    let sample = path_sample(index);
    let l = luminance(sample);
    let scale = BOUND * sqrt(count);
    let own = nearby_level(pixel);
    // Within the bound of its own neighbourhood: not an outlier, whatever its surface reads
    // (nearly every pixel: the window is read only for the others).
    if !(l > scale * own) {
        return;
    }
    let n = textureLoad(gbuffer_normal, pixel, 0);
    var sums = surface_sums(pixel, at, n, RADIUS, false);
    let limit = scale * max(own, sums.x / sums.y);
    if !(l > limit) || !(sums.x > 0.0) {
        return;
    }
    let wanted = (l - limit) / scale;
    var over = widened(pixel, at, n, wanted, sums, false);
    // A surface too thin to take it within twice its bound (a pane's edge seen edge-on: a
    // strip a pixel wide, where the spread gave most of it back to the pixel itself) shares
    // it with every surface around, sized the same way from what they read.
    let any_surface = wanted > 2.0 * over.sums.x;
    if any_surface {
        over = widened(pixel, at, n, wanted, surface_sums(pixel, at, n, RADIUS, true), true);
    }
    // w: the radius, and (twice its fraction, under 1 so that it never rounds up to the next
    // radius) the share of the sample the pixel keeps; negative where any surface takes it.
    let w = f32(over.radius) + 0.5 * (limit / l);
    excess[index] = vec4<f32>(sample * ((1.0 - limit / l) / over.sums.x), select(w, -w, any_surface));
}

struct Spread {
    radius: i32,
    sums: vec2<f32>,
}

// The window `wanted` is spread over, from the `surface_sums` over RADIUS (`at_radius`):
// there, the pixels would take it in proportion to levels summing to at_radius.x, past
// their own bound where that is above wanted. A window's sum grows with its area, so a
// radius √ that ratio larger keeps them within it (up to MOST_RADIUS).
fn widened(pixel: vec2<i32>, at: vec4<f32>, n: vec4<f32>, wanted: f32, at_radius: vec2<f32>, any_surface: bool) -> Spread {
    if !(wanted > at_radius.x) {
        return Spread(RADIUS, at_radius);
    }
    let radius = min(i32(ceil(f32(RADIUS) * sqrt(wanted / at_radius.x))), MOST_RADIUS);
    return Spread(radius, surface_sums(pixel, at, n, radius, any_surface));
}

// The levels of the pixels of this pixel's surface within `radius`, weighed by their
// kinship, and (y) the kinships' sum.
fn surface_sums(pixel: vec2<i32>, at: vec4<f32>, n: vec4<f32>, radius: i32, any_surface: bool) -> vec2<f32> {
    let w = window(pixel, radius);
    var sums = vec2<f32>(0.0);
    for (var row = w.lo.y; row <= w.hi.y; row += 1) {
        for (var column = w.lo.x; column <= w.hi.x; column += 1) {
            let q = vec2<i32>(column, row);
            let k = kinship(at, n, textureLoad(gbuffer_position, q, 0), textureLoad(gbuffer_normal, q, 0), q - pixel, radius, any_surface);
            if k > 0.0 {
                sums += vec2<f32>(k * level(q), k);
            }
        }
    }
    return sums;
}

// How far this workgroup's pixels look for light spread to them: the largest radius of
// those within MOST_RADIUS that reach it (0: none).
var<workgroup> reach: atomic<i32>;

// Takes from this pixel's sample what it spreads and adds its share of what its surface's
// pixels around it spread, in proportion to its estimate.
@compute @workgroup_size(8, 8, 1)
fn spread(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(local_invocation_index) lane: u32,
) {
    // Outliers are rare: a workgroup with none around it stops after a few reads a pixel.
    if lane == 0u {
        atomicStore(&reach, 0);
    }
    workgroupBarrier();
    let side = 8 + 2 * MOST_RADIUS;
    let lo = vec2<i32>(group.xy * 8u);
    let origin = lo - MOST_RADIUS;
    for (var k = i32(lane); k < side * side; k += 64) {
        let q = origin + vec2<i32>(k % side, k / side);
        if all(q >= vec2<i32>(0)) && all(q < vec2<i32>(params.size)) {
            let share = excess[pixel_index(q)];
            // Pixels from this workgroup's square (0 inside it).
            let apart = max(max(lo - q, q - (lo + 7)), vec2<i32>(0));
            let radius = i32(abs(share.w));
            if share.w != 0.0 && max(apart.x, apart.y) <= radius {
                atomicMax(&reach, radius);
            }
        }
    }
    let radius = workgroupUniformLoad(&reach);
    if radius == 0 || any(id.xy >= params.size) {
        return;
    }
    let pixel = vec2<i32>(id.xy);
    let index = pixel_index(pixel);
    let at = textureLoad(gbuffer_position, pixel, 0);
    if at.w == 0.0 {
        return;
    }
    var own = importon_radiance[index].w;
    if params.iteration != 0u {
        own = level(pixel);
    }
    let n = textureLoad(gbuffer_normal, pixel, 0);
    let w = window(pixel, radius);
    let given = excess[index];
    var got = vec3<f32>(0.0);
    for (var row = w.lo.y; row <= w.hi.y; row += 1) {
        for (var column = w.lo.x; column <= w.hi.x; column += 1) {
            let q = vec2<i32>(column, row);
            let share = excess[pixel_index(q)];
            if share.w != 0.0 {
                let k = kinship(at, n, textureLoad(gbuffer_position, q, 0), textureLoad(gbuffer_normal, q, 0), q - pixel, i32(abs(share.w)), share.w < 0.0);
                got += share.rgb * (k * own);
            }
        }
    }
    if given.w != 0.0 {
        // What it spreads scales both parts of its sample alike.
        let kept = 2.0 * fract(abs(given.w));
        samples[index] = vec4<f32>(samples[index].rgb * kept, samples[index].w);
        importon_radiance[index] = vec4<f32>(importon_radiance[index].rgb * kept, importon_radiance[index].w);
    }
    samples[index] += vec4<f32>(got, 0.0);
}
