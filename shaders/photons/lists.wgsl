// The stored photons as photon tracing lists them, per deep-cubemap tile, for the gathers of
// both splats (group 2, bindings 0 and 1 of their stages).
#define_import_path bevy_rppm::photon_lists

#import bevy_rppm::common::{Photon, LIST_BLOCK, list_block}
#import bevy_rppm::cubemap::cubemap

@group(2) @binding(0) var<storage, read> photons: array<Photon>;
// Per cubemap tile, the head of its photon list (index + 1); then the blocks' flags.
@group(2) @binding(1) var<storage, read> photon_heads: array<u32>;

// Whether a photon is listed in any block that tiles (x0, x1, y0, y1) of `face` touch.
fn listed(face: u32, tiles: vec4<i32>) -> bool {
    for (var y = u32(tiles.z) / LIST_BLOCK; y <= u32(tiles.w) / LIST_BLOCK; y += 1u) {
        for (var x = u32(tiles.x) / LIST_BLOCK; x <= u32(tiles.y) / LIST_BLOCK; x += 1u) {
            if photon_heads[list_block(cubemap, face, x * LIST_BLOCK, y * LIST_BLOCK)] != 0u {
                return true;
            }
        }
    }
    return false;
}

// The head of the list of tile (x, y) of `face`.
fn list_head(face: u32, x: i32, y: i32) -> u32 {
    return photon_heads[(face * cubemap.grid + u32(y)) * cubemap.grid + u32(x)];
}
