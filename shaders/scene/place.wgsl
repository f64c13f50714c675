// The scene's world-space triangles: each instance's mesh through its transform
// (src/scene/place.rs). Runs when an instance or a mesh changed, not every iteration, and
// marks the triangles it moved: `place` against where the buffer had them, `place_new` into a
// new buffer, whose triangles none moved (a still scene's history reads them as still).

#import bevy_rppm::common::{MOVED_TRIANGLE, PackedTriangle, pack_normal, unpack_normal}

struct Instance {
    // World from local by rows (w: translation), and the normals' inverse transpose.
    rows: array<vec4<f32>, 3>,
    normal_rows: array<vec4<f32>, 3>,
    first_local: u32,
    first_world: u32,
    triangle_count: u32,
    material: u32,
    mirrored: u32,
    mesh: u32,
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(0) var<storage, read> local_triangles: array<PackedTriangle>;
@group(0) @binding(1) var<storage, read> instances: array<Instance>;
@group(0) @binding(2) var<storage, read_write> triangles: array<PackedTriangle>;

fn point(i: Instance, p: vec3<f32>) -> vec3<f32> {
    let q = vec4<f32>(p, 1.0);
    return vec3<f32>(dot(i.rows[0], q), dot(i.rows[1], q), dot(i.rows[2], q));
}

fn normal(i: Instance, packed: u32) -> u32 {
    let n = unpack_normal(packed);
    let m = vec3<f32>(dot(i.normal_rows[0].xyz, n), dot(i.normal_rows[1].xyz, n), dot(i.normal_rows[2].xyz, n));
    let len = length(m);
    return pack_normal(select(vec3<f32>(0.0, 0.0, 1.0), m / len, len > 0.0));
}

@compute @workgroup_size(64)
fn place(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    place_triangle((group.y * groups.x + group.x) * 64u + lane, true);
}

@compute @workgroup_size(64)
fn place_new(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    place_triangle((group.y * groups.x + group.x) * 64u + lane, false);
}

// Places triangle `index`, marked if `marks` and it moved from where the buffer held it.
fn place_triangle(index: u32, marks: bool) {
    let count = arrayLength(&instances);
    let last = instances[count - 1u];
    if index >= last.first_world + last.triangle_count {
        return;
    }
    // The instance holding `index`: the last whose first triangle is at or before it.
    var lo = 0u;
    var hi = count - 1u;
    while lo < hi {
        let mid = (lo + hi + 1u) / 2u;
        if instances[mid].first_world <= index {
            lo = mid;
        } else {
            hi = mid - 1u;
        }
    }
    let inst = instances[lo];
    let t = local_triangles[inst.first_local + index - inst.first_world];
    let a = point(inst, vec3<f32>(t.ax, t.ay, t.az));
    var b = point(inst, vec3<f32>(t.bx, t.by, t.bz));
    var c = point(inst, vec3<f32>(t.cx, t.cy, t.cz));
    let na = normal(inst, t.normal_a);
    var nb = normal(inst, t.normal_b);
    var nc = normal(inst, t.normal_c);
    // A mirroring transform flips the winding: swap two corners so the front stays in front.
    if inst.mirrored != 0u {
        let p = b;
        b = c;
        c = p;
        let n = nb;
        nb = nc;
        nc = n;
    }
    // Whether this placement moved the triangle from where the last one put it.
    var moved = false;
    if marks {
        let old = triangles[index];
        moved = any(vec3<f32>(old.ax, old.ay, old.az) != a) || any(vec3<f32>(old.bx, old.by, old.bz) != b)
            || any(vec3<f32>(old.cx, old.cy, old.cz) != c);
    }
    let material = inst.material | select(0u, MOVED_TRIANGLE, moved);
    triangles[index] = PackedTriangle(a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z, material, na, nb, nc);
}
