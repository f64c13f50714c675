// The stored photons as photon tracing lists them, per deep-cubemap tile, for the gathers of
// both splats (group 2, bindings 0 and 1 of their stages).
#define_import_path bevy_rppm::photon_lists

#import bevy_rppm::common::{Photon, IterationParams, LIST_BLOCK, list_block, face_tiles, splat_survives}
#import bevy_rppm::cubemap::cubemap

@group(2) @binding(0) var<storage, read> photons: array<Photon>;
// Per cubemap tile, the head of its photon list (index + 1); then the blocks' flags.
@group(2) @binding(1) var<storage, read> photon_heads: array<u32>;

// The tiles of `face` that a sphere of radius r around p reaches (face_tiles), or none
// (x0 > x1) when no photon is listed in the blocks they touch.
fn listed_tiles(face: u32, p: vec3<f32>, r: f32) -> vec4<i32> {
    let tiles = face_tiles(cubemap, p, r, face);
    if tiles.x > tiles.y {
        return tiles;
    }
    for (var y = u32(tiles.z) / LIST_BLOCK; y <= u32(tiles.w) / LIST_BLOCK; y += 1u) {
        for (var x = u32(tiles.x) / LIST_BLOCK; x <= u32(tiles.y) / LIST_BLOCK; x += 1u) {
            if photon_heads[list_block(cubemap, face, x * LIST_BLOCK, y * LIST_BLOCK)] != 0u {
                return tiles;
            }
        }
    }
    return vec4<i32>(1, 0, 1, 0);
}

// Whether photon `photon` is inside the gather kernel of `pixel` (centre, plane normal,
// radius r): within r of the centre, near its plane and facing the same way (either way on
// a surface that lets diffuse light through, `both_sides`), and kept by the splat's
// roulette. Read field by field: most photons fail the first test.
fn in_kernel(params: IterationParams, photon: u32, centre: vec3<f32>, plane: vec3<f32>, r: f32, pixel: u32, both_sides: bool) -> bool {
    let offset = photons[photon].position - centre;
    if dot(offset, offset) > r * r || abs(dot(offset, plane)) > params.kernel_flattening * r {
        return false;
    }
    let facing = dot(photons[photon].normal, plane);
    return select(facing, abs(facing), both_sides) >= 0.5 && splat_survives(params, photon, pixel);
}

// From list node `node` (photon index + 1) on, the first photon inside the kernel of `pixel`
// (in_kernel), as a node; 0 at the end of the list or after `walked` reaches the photon count
// (a guard). The gathers evaluate the BSDF only for these: llvmpipe runs a loop body's code
// for every lane, so a BSDF behind a `continue` was paid for every photon walked past.
fn next_in_kernel(node: u32, walked: ptr<function, u32>, params: IterationParams, centre: vec3<f32>, plane: vec3<f32>, r: f32, pixel: u32, both_sides: bool) -> u32 {
    var at = node;
    loop {
        if at == 0u || *walked >= arrayLength(&photons) {
            return 0u;
        }
        *walked += 1u;
        if in_kernel(params, at - 1u, centre, plane, r, pixel, both_sides) {
            return at;
        }
        at = photons[at - 1u].next;
    }
    return 0u;
}

// The head of the list of tile (x, y) of `face`.
fn list_head(face: u32, x: i32, y: i32) -> u32 {
    return photon_heads[(face * cubemap.grid + u32(y)) * cubemap.grid + u32(x)];
}
