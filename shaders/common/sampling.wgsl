// The random numbers of every stage: a PCG hash of (iteration, item, draw), and for a camera
// path's first draws Owen-scrambled Sobol pairs over iterations (`stratified_draws`).
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
