// The photon map: the stored photons ordered by cubemap tile (a counting sort), so that a
// row of tiles is one run of the map. The gathers then read neighbouring photons from
// neighbouring memory instead of following per-tile lists through the whole store, and an
// empty row costs two loads.
//   scan_blocks: exclusive prefix sums of the tile counts, per block of SCAN_BLOCK tiles;
//   scan_sums: prefix sums of the blocks' totals, the photon count and the scatter's dispatch;
//   scan_add: adds each block's offset to its tiles' starts;
//   scatter: copies each photon (a `Photon` of common.wgsl) to its tile's run.

// The tiles four to a vec4 (the buffers are padded to whole quads): llvmpipe loads a storage
// buffer lane by lane, and a quad is one load.
// Per tile, the photons stored in it.
@group(0) @binding(0) var<storage, read> tile_counts: array<vec4<u32>>;
// Per tile, its first photon in the map; then the photon count (x of the last quad).
@group(0) @binding(1) var<storage, read_write> tile_starts: array<vec4<u32>>;
// The scans' own (group 1 of their layout): per block of tiles, its total, then its offset;
// the scatter's workgroups (x, y, z), apart from the scatter, which dispatches with them.
@group(1) @binding(0) var<storage, read_write> block_sums: array<u32>;
@group(1) @binding(1) var<storage, read_write> scatter_groups: array<u32, 3>;
// The scatter's own: the photons as tracing stored them (two quads each), the tile and
// rank in it of each, and the map.
@group(1) @binding(2) var<storage, read> stored: array<vec4<u32>>;
@group(1) @binding(3) var<storage, read> photon_tiles: array<vec2<u32>>;
@group(1) @binding(4) var<storage, read_write> photons: array<vec4<u32>>;

const SCAN_LANES: u32 = 256u;
// Tiles a scan_blocks workgroup sums: four quads a lane.
const SCAN_BLOCK: u32 = 4096u;
const LANE_QUADS: u32 = 4u;
// Threads of a scatter workgroup.
const SCATTER_LANES: u32 = 256u;

var<workgroup> partial: array<u32, SCAN_LANES>;

// The sum of `value` over the workgroup's lanes before `lane` (Hillis-Steele); the whole
// workgroup's sum is left in partial[SCAN_LANES - 1].
fn workgroup_scan(lane: u32, value: u32) -> u32 {
    partial[lane] = value;
    workgroupBarrier();
    for (var d = 1u; d < SCAN_LANES; d *= 2u) {
        var before = 0u;
        if lane >= d {
            before = partial[lane - d];
        }
        workgroupBarrier();
        partial[lane] += before;
        workgroupBarrier();
    }
    return partial[lane] - value;
}

fn quad_sum(q: vec4<u32>) -> u32 {
    return q.x + q.y + q.z + q.w;
}

@compute @workgroup_size(256, 1, 1)
fn scan_blocks(@builtin(local_invocation_index) lane: u32, @builtin(workgroup_id) group: vec3<u32>) {
    let quads = arrayLength(&tile_counts);
    let first = group.x * (SCAN_BLOCK / 4u) + lane * LANE_QUADS;
    var counts: array<vec4<u32>, LANE_QUADS>;
    var sum = 0u;
    for (var k = 0u; k < LANE_QUADS; k += 1u) {
        if first + k < quads {
            counts[k] = tile_counts[first + k];
        }
        sum += quad_sum(counts[k]);
    }
    var start = workgroup_scan(lane, sum);
    for (var k = 0u; k < LANE_QUADS; k += 1u) {
        let c = counts[k];
        if first + k < quads {
            tile_starts[first + k] = start + vec4<u32>(0u, c.x, c.x + c.y, c.x + c.y + c.z);
        }
        start += quad_sum(c);
    }
    if lane == SCAN_LANES - 1u {
        block_sums[group.x] = partial[lane];
    }
}

// One workgroup: each lane takes a run of the blocks.
@compute @workgroup_size(256, 1, 1)
fn scan_sums(@builtin(local_invocation_index) lane: u32) {
    let quads = arrayLength(&tile_counts);
    let blocks = (quads + SCAN_BLOCK / 4u - 1u) / (SCAN_BLOCK / 4u);
    let run = (blocks + SCAN_LANES - 1u) / SCAN_LANES;
    let first = min(lane * run, blocks);
    let last = min(first + run, blocks);
    var sum = 0u;
    for (var b = first; b < last; b += 1u) {
        sum += block_sums[b];
    }
    var offset = workgroup_scan(lane, sum);
    for (var b = first; b < last; b += 1u) {
        let total = block_sums[b];
        block_sums[b] = offset;
        offset += total;
    }
    if lane == SCAN_LANES - 1u {
        let total = partial[lane];
        tile_starts[quads] = vec4<u32>(total, 0u, 0u, 0u);
        scatter_groups = array<u32, 3>(min((total + SCATTER_LANES - 1u) / SCATTER_LANES, 65535u), 1u, 1u);
    }
}

@compute @workgroup_size(256, 1, 1)
fn scan_add(@builtin(local_invocation_index) lane: u32, @builtin(workgroup_id) group: vec3<u32>) {
    let quads = arrayLength(&tile_counts);
    let first = group.x * (SCAN_BLOCK / 4u) + lane * LANE_QUADS;
    let offset = block_sums[group.x];
    for (var k = 0u; k < LANE_QUADS; k += 1u) {
        if first + k < quads {
            tile_starts[first + k] += vec4<u32>(offset);
        }
    }
}

// Photon tracing counted each photon's rank in its tile; the order within a tile is its
// atomics' (it changes only the order of the gathers' sums). A grid-stride loop: a
// dispatch holds at most 65535 workgroups.
@compute @workgroup_size(256, 1, 1)
fn scatter(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let photons_stored = tile_starts[arrayLength(&tile_counts)].x;
    for (var i = id.x; i < photons_stored; i += groups.x * SCATTER_LANES) {
        let tile = photon_tiles[i];
        let at = tile_starts[tile.x / 4u][tile.x % 4u] + tile.y;
        photons[2u * at] = stored[2u * i];
        photons[2u * at + 1u] = stored[2u * i + 1u];
    }
}
