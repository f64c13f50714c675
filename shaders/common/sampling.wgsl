// The random numbers of every stage: a PCG hash of (iteration, item, draw), and for a camera
// path's first draws a Kronecker sequence over iterations (`stratified_draws`).
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

// From here the invocation's first STRATIFIED_DIMENSIONS `random` draws come from a Kronecker
// sequence (Roberts' R_8) indexed by the iteration and shifted per `item`: over iterations an
// item's draws (a pixel's Fresnel choice, light sample) stratify instead of falling
// independently, while each iteration's stays uniform (unbiased).
fn stratified_draws(item: u32, index: u32) {
    stratified_left = STRATIFIED_DIMENSIONS;
    stratified_index = index;
    stratified_shift = pcg_hash(item ^ 0x2545f491u);
}

// Step of R_8's dimension d, in units of 2⁻³²: (1/φ₈)^(d+1), φ₈ the root of x⁹ = x + 1.
fn kronecker_step(d: u32) -> u32 {
    switch d {
        case 0u: { return 0xebedeed9u; }
        case 1u: { return 0xd96eb1a8u; }
        case 2u: { return 0xc862b36du; }
        case 3u: { return 0xb8acd90cu; }
        case 4u: { return 0xaa324f90u; }
        case 5u: { return 0x9cda5e69u; }
        case 6u: { return 0x908e3d2cu; }
        default: { return 0x8538ecb5u; }
    }
}

// Uniform in [0, 1), advancing `state`.
fn random(state: ptr<function, u32>) -> f32 {
    if stratified_left > 0u {
        let d = STRATIFIED_DIMENSIONS - stratified_left;
        stratified_left -= 1u;
        // Modulo 2³² exactly: no precision lost however far the index runs.
        let u = pcg_hash(stratified_shift + d * 0x9e3779b9u) + stratified_index * kronecker_step(d);
        return f32(u >> 8u) / 16777216.0;
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
