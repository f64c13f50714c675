// The deep-cubemap correctness harness (DIRT): the same rays traced through the deep cubemap,
// by brute force, and through the bounding-volume hierarchy (the peer, src/cubemap/bvh/).
#import bevy_rppm::cubemap::{trace_cubemap, trace_bvh, Hit, RayFrame, ray_frame, consider, NO_HIT}
#import bevy_rppm::scene::triangles

struct Ray {
    // xyz origin, w t_min.
    origin: vec4<f32>,
    // xyz direction; w the triangle the ray leaves, as bits (0xffffffff for none).
    direction: vec4<f32>,
}

@group(2) @binding(0) var<storage, read> rays: array<Ray>;
@group(2) @binding(1) var<storage, read_write> hits: array<vec4<f32>>;

// Triangle `id` where it is below `count` and not `ignore`.
fn consider_some(r: RayFrame, id: u32, count: u32, t_min: f32, ignore: u32, best: ptr<function, Hit>) {
    if id < count && id != ignore {
        consider(r, id, t_min, best);
    }
}

// Eight consecutive triangles from `first`, written out (no loop: see trace_brute_force).
fn consider_eight(r: RayFrame, first: u32, count: u32, t_min: f32, ignore: u32, best: ptr<function, Hit>) {
    consider_some(r, first, count, t_min, ignore, best);
    consider_some(r, first + 1u, count, t_min, ignore, best);
    consider_some(r, first + 2u, count, t_min, ignore, best);
    consider_some(r, first + 3u, count, t_min, ignore, best);
    consider_some(r, first + 4u, count, t_min, ignore, best);
    consider_some(r, first + 5u, count, t_min, ignore, best);
    consider_some(r, first + 6u, count, t_min, ignore, best);
    consider_some(r, first + 7u, count, t_min, ignore, best);
}

// The reference: every triangle, nearest hit in (t_min, t_max), skipping `ignore`. llvmpipe
// ends a loop after 65 535 iterations in all (however often it is entered), so the triangles
// are taken 32 at a time, in two loops: up to 4 M triangles.
fn trace_brute_force(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32, ignore: u32) -> Hit {
    var best = Hit(t_max, NO_HIT, vec2<f32>(0.0));
    let r = ray_frame(o, d);
    let count = arrayLength(&triangles);
    let half = (count / 64u + 1u) * 32u;
    for (var i = 0u; i < half; i += 32u) {
        consider_eight(r, i, count, t_min, ignore, &best);
        consider_eight(r, i + 8u, count, t_min, ignore, &best);
        consider_eight(r, i + 16u, count, t_min, ignore, &best);
        consider_eight(r, i + 24u, count, t_min, ignore, &best);
    }
    for (var i = half; i < count; i += 32u) {
        consider_eight(r, i, count, t_min, ignore, &best);
        consider_eight(r, i + 8u, count, t_min, ignore, &best);
        consider_eight(r, i + 16u, count, t_min, ignore, &best);
        consider_eight(r, i + 24u, count, t_min, ignore, &best);
    }
    return best;
}

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

@compute @workgroup_size(64, 1, 1)
fn bvh(@builtin(global_invocation_id) id: vec3<u32>) {
    let count = arrayLength(&hits);
    if id.x >= count {
        return;
    }
    let ray = rays[id.x % arrayLength(&rays)];
    store(id.x, trace_bvh(ray.origin.xyz, ray.direction.xyz, ray.origin.w, 1.0e30, bitcast<u32>(ray.direction.w), false));
}
