// The deep-cubemap correctness harness (DIRT): the same rays traced through the deep cubemap,
// by brute force, and through the bounding-volume hierarchy (the peer, src/cubemap/bvh/).
#import bevy_rppm::cubemap::{trace_cubemap, trace_bvh, trace_brute_force, Hit}

struct Ray {
    // xyz origin, w t_min.
    origin: vec4<f32>,
    // xyz direction; w the triangle the ray leaves, as bits (0xffffffff for none).
    direction: vec4<f32>,
}

@group(2) @binding(0) var<storage, read> rays: array<Ray>;
@group(2) @binding(1) var<storage, read_write> hits: array<vec4<f32>>;

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
