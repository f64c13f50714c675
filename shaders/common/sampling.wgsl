// The random numbers of every stage: a PCG hash of (iteration, item, draw), and for a camera
// path's first draws Owen-scrambled Sobol pairs over iterations (`stratified_draws`); and
// the draws of a direction toward a sphere or a triangle.
#define_import_path bevy_rppm::sampling

// A PCG hash: the random numbers of every stage come from hashing (iteration, item, draw).
fn pcg_hash(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Draws left for `stratified_draws`' sequence in this invocation (0: none, the hash alone).
var<private> stratified_left: u32;
var<private> stratified_index: u32;
var<private> stratified_shift: u32;

// Numbers of dimensions a camera path draws from a sequence rather than the hash.
const STRATIFIED_DIMENSIONS: u32 = 8u;

// From here the invocation's first STRATIFIED_DIMENSIONS `random` draws come from a
// sequence indexed by the iteration and scrambled per `item`: over iterations an item's draws
// (a pixel's Fresnel choice, light sample) stratify instead of falling independently, while
// each iteration's stays uniform (unbiased).
fn stratified_draws(item: u32, index: u32) {
    stratified_left = STRATIFIED_DIMENSIONS;
    stratified_index = index;
    stratified_shift = pcg_hash(item ^ 0x2545f491u);
}

// Laine and Karras's hash: a permutation of the bits in which each bit depends only on those
// below it, so on reversed bits an Owen scrambling (Burley 2020, "Practical hash-based Owen
// scrambling").
fn laine_karras(x: u32, seed: u32) -> u32 {
    var v = x + seed;
    v ^= v * 0x6c50b47cu;
    v ^= v * 0xb82f1e52u;
    v ^= v * 0xc7afe638u;
    v ^= v * 0x8d22f6e6u;
    return v;
}

fn owen_scramble(x: u32, seed: u32) -> u32 {
    return reverseBits(laine_karras(reverseBits(x), seed));
}

// Sobol's second dimension of point n, as a 32-bit fraction (its first is reverseBits(n)).
fn sobol_second(n: u32) -> u32 {
    var r = 0u;
    var v = 0x80000000u;
    var i = n;
    while i != 0u {
        if (i & 1u) != 0u {
            r ^= v;
        }
        i >>= 1u;
        v ^= v >> 1u;
    }
    return r;
}

// Draw d of the sequence: pairs of draws are 2D Sobol points, the index shuffled and each
// coordinate Owen-scrambled by a seed of the item and the pair, so that pairs stay
// independent of each other (Roberts' R₈ over all eight had consecutive draws nearly in
// step: a light sample drawn from them stratified worse than none).
fn sequence_draw(d: u32) -> u32 {
    let seed = pcg_hash(stratified_shift + (d / 2u) * 0x9e3779b9u);
    let n = owen_scramble(stratified_index, seed);
    if d % 2u == 0u {
        return owen_scramble(reverseBits(n), pcg_hash(seed ^ 0x68bc21ebu));
    }
    return owen_scramble(sobol_second(n), pcg_hash(seed ^ 0x02e5be93u));
}

// Uniform in [0, 1), advancing `state`.
fn random(state: ptr<function, u32>) -> f32 {
    if stratified_left > 0u {
        let d = STRATIFIED_DIMENSIONS - stratified_left;
        stratified_left -= 1u;
        return f32(sequence_draw(d) >> 8u) / 16777216.0;
    }
    *state = pcg_hash(*state);
    return f32(*state >> 8u) / 16777216.0;
}

// 1 − cos of the half-angle of the cone a sphere of radius r subtends from squared distance
// d2, without cancelling for a small or far sphere; 0 from inside it.
fn sphere_cap(r: f32, d2: f32) -> f32 {
    if r <= 0.0 || d2 <= r * r * 1.0001 {
        return 0.0;
    }
    let sin2 = r * r / d2;
    return sin2 / (1.0 + sqrt(1.0 - sin2));
}

// A direction uniform in solid angle within the cone about +z whose half-angle has
// 1 − cos = `one_minus`, from u in [0, 1)²; basis_around(axis) turns it about an axis.
fn cone_local(one_minus: f32, u: vec2<f32>) -> vec3<f32> {
    let cos_t = 1.0 - u.x * one_minus;
    let sin_t = sqrt(max(u.x * one_minus * (2.0 - u.x * one_minus), 0.0));
    let phi = 6.2831855 * u.y;
    return vec3<f32>(sin_t * cos(phi), sin_t * sin(phi), cos_t);
}

// A direction uniform in the solid angle the triangle (a, b, c) subtends from x (Arvo 1995, as
// pbrt-v4 writes it), as barycentrics (b, c) of where it meets the triangle, and that solid
// angle in z (0: too thin to sample, the caller draws by area instead). No inverse
// trigonometry: a GPU's asin and a sum of angles less π lose a small triangle's area.
fn spherical_triangle(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, x: vec3<f32>, u: vec2<f32>) -> vec3<f32> {
    let wa = normalize(a - x);
    let wb = normalize(b - x);
    let wc = normalize(c - x);
    // Van Oosterom and Strackee's solid angle.
    let area = 2.0 * atan2(abs(dot(wa, cross(wb, wc))), 1.0 + dot(wa, wb) + dot(wb, wc) + dot(wc, wa));
    let cab = cross(wa, wb);
    let cca = cross(wc, wa);
    if area <= 0.0 || min(dot(cab, cab), dot(cca, cca)) < 1e-12 {
        return vec3<f32>(0.0);
    }
    // The angle at a, between the planes through a and b and through a and c.
    let n_ab = normalize(cab);
    let n_ca = normalize(cca);
    let cos_alpha = -dot(n_ab, n_ca);
    let sin_alpha = length(cross(n_ab, n_ca));
    // The sub-triangle of area u.x × area, then a point along its last edge.
    let swept = u.x * area;
    let sin_s = sin(swept);
    let cos_s = cos(swept);
    let sin_phi = cos_s * sin_alpha - sin_s * cos_alpha;
    let cos_phi = -cos_s * cos_alpha - sin_s * sin_alpha;
    let k1 = cos_phi + cos_alpha;
    let k2 = sin_phi - sin_alpha * dot(wa, wb);
    let cos_bp = clamp((k2 + (k2 * cos_phi - k1 * sin_phi) * cos_alpha) / ((k2 * sin_phi + k1 * cos_phi) * sin_alpha), -1.0, 1.0);
    let sin_bp = sqrt(max(1.0 - cos_bp * cos_bp, 0.0));
    let cp = cos_bp * wa + sin_bp * normalize(wc - dot(wc, wa) * wa);
    let cos_t = 1.0 - u.y * (1.0 - dot(cp, wb));
    let sin_t = sqrt(max(1.0 - cos_t * cos_t, 0.0));
    let w = cos_t * wb + sin_t * normalize(cp - dot(cp, wb) * wb);
    // Where w meets the triangle's plane (Möller–Trumbore).
    let e1 = b - a;
    let e2 = c - a;
    let s1 = cross(w, e2);
    let divisor = dot(s1, e1);
    if abs(divisor) < 1e-20 {
        return vec3<f32>(0.0);
    }
    let s = x - a;
    var b1 = clamp(dot(s, s1) / divisor, 0.0, 1.0);
    var b2 = clamp(dot(w, cross(s, e1)) / divisor, 0.0, 1.0);
    let sum = b1 + b2;
    if sum > 1.0 {
        b1 /= sum;
        b2 /= sum;
    }
    return vec3<f32>(b1, b2, area);
}

// x in [0, 1) drawn with density linear from a (at 0) to b (at 1), from u.
fn linear_sample(u: f32, a: f32, b: f32) -> f32 {
    return min(u * (a + b) / (a + sqrt(mix(a * a, b * b, u))), 0.99999994);
}

// A point of [0, 1)² drawn with density bilinear in the corner weights w (00, 10, 01, 11).
fn bilinear_sample(u: vec2<f32>, w: vec4<f32>) -> vec2<f32> {
    let y = linear_sample(u.y, w.x + w.y, w.z + w.w);
    return vec2<f32>(linear_sample(u.x, mix(w.x, w.z, y), mix(w.y, w.w, y)), y);
}

// The density of `bilinear_sample` at p.
fn bilinear_density(p: vec2<f32>, w: vec4<f32>) -> f32 {
    let q = 1.0 - p;
    return 4.0 * (q.x * q.y * w.x + p.x * q.y * w.y + q.x * p.y * w.z + p.x * p.y * w.w) / (w.x + w.y + w.z + w.w);
}
