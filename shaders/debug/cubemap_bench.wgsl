// The deep-cubemap correctness harness (DIRT): the same rays traced through the deep cubemap,
// by brute force, and through a bounding-volume hierarchy (the peer, src/debug/bvh/).
#import bevy_rppm::cubemap::{trace_cubemap, trace_brute_force, consider, Hit, NO_HIT}

struct Ray {
    // xyz origin, w t_min.
    origin: vec4<f32>,
    // xyz direction; w the triangle the ray leaves, as bits (0xffffffff for none).
    direction: vec4<f32>,
}

@group(2) @binding(0) var<storage, read> rays: array<Ray>;
@group(2) @binding(1) var<storage, read_write> hits: array<vec4<f32>>;

// BvhNode in src/debug/bvh/build.rs: a leaf's triangles are bvh_indices[first..first + count];
// an inner node (count INNER) has children first and first + 1.
struct BvhNode {
    min: vec3<f32>,
    first: u32,
    max: vec3<f32>,
    count: u32,
}

const INNER: u32 = 0xffffffffu;
// MAX_DEPTH in src/debug/bvh/build.rs.
const BVH_STACK: u32 = 48u;

@group(2) @binding(2) var<storage, read> bvh_nodes: array<BvhNode>;
@group(2) @binding(3) var<storage, read> bvh_indices: array<u32>;

fn store(i: u32, h: Hit) {
    hits[i] = vec4<f32>(h.t, bitcast<f32>(h.triangle), h.uv);
}

@compute @workgroup_size(64, 1, 1)
fn trace(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = arrayLength(&rays);
    // Rays are reused cyclically so that timing runs can trace more rays than are stored.
    let count = arrayLength(&hits);
    if id.x >= count {
        return;
    }
    let ray = rays[id.x % n];
    store(id.x, trace_cubemap(ray.origin.xyz, ray.direction.xyz, ray.origin.w, 1.0e30, bitcast<u32>(ray.direction.w)));
}

@compute @workgroup_size(64, 1, 1)
fn brute_force(@builtin(global_invocation_id) id: vec3<u32>) {
    let count = arrayLength(&hits);
    if id.x >= count {
        return;
    }
    let ray = rays[id.x % arrayLength(&rays)];
    store(id.x, trace_brute_force(ray.origin.xyz, ray.direction.xyz, ray.origin.w, 1.0e30, bitcast<u32>(ray.direction.w)));
}

// Where the ray enters a node's box within (0, t_max), or FAR_BOX on a miss.
const FAR_BOX: f32 = 3.0e38;

fn enter_box(o: vec3<f32>, inv: vec3<f32>, n: BvhNode, t_max: f32) -> f32 {
    let t0 = (n.min - o) * inv;
    let t1 = (n.max - o) * inv;
    let lo = min(t0, t1);
    let hi = max(t0, t1);
    let near = max(max(lo.x, lo.y), max(lo.z, 0.0));
    let far = min(min(hi.x, hi.y), min(hi.z, t_max));
    return select(FAR_BOX, near, near <= far);
}

// Nearest hit by a stack walk of the hierarchy, nearer child first; triangles are tested as
// brute force tests them.
fn trace_bvh(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32, ignore: u32) -> Hit {
    var best = Hit(t_max, NO_HIT, vec2<f32>(0.0));
    // A zero component's reciprocal as a huge number of its sign, never NaN in the slabs.
    let inv = 1.0 / select(d, vec3<f32>(1e-30), abs(d) < vec3<f32>(1e-30));
    var stack: array<u32, BVH_STACK>;
    var top = 0u;
    var node = 0u;
    if enter_box(o, inv, bvh_nodes[0], t_max) == FAR_BOX {
        return best;
    }
    loop {
        let n = bvh_nodes[node];
        if n.count != INNER {
            for (var k = n.first; k < n.first + n.count; k += 1u) {
                let id = bvh_indices[k];
                if id != ignore {
                    consider(o, d, id, t_min, &best);
                }
            }
        } else {
            let a = enter_box(o, inv, bvh_nodes[n.first], best.t);
            let b = enter_box(o, inv, bvh_nodes[n.first + 1u], best.t);
            let near = select(n.first + 1u, n.first, a <= b);
            if min(a, b) < FAR_BOX {
                if max(a, b) < FAR_BOX && top < BVH_STACK {
                    stack[top] = select(n.first, n.first + 1u, a <= b);
                    top += 1u;
                }
                node = near;
                continue;
            }
        }
        // Pop the next node the current best may still be beaten in.
        var found = false;
        while top > 0u && !found {
            top -= 1u;
            node = stack[top];
            found = enter_box(o, inv, bvh_nodes[node], best.t) < FAR_BOX;
        }
        if !found {
            break;
        }
    }
    return best;
}

@compute @workgroup_size(64, 1, 1)
fn bvh(@builtin(global_invocation_id) id: vec3<u32>) {
    let count = arrayLength(&hits);
    if id.x >= count {
        return;
    }
    let ray = rays[id.x % arrayLength(&rays)];
    store(id.x, trace_bvh(ray.origin.xyz, ray.direction.xyz, ray.origin.w, 1.0e30, bitcast<u32>(ray.direction.w)));
}
