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
