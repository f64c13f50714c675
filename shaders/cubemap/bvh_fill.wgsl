// The BVH's triangles texture (trace.wgsl's `bvh_triangles`): the corners of the scene's
// placed triangles in the hierarchy's leaf order, copied on the GPU so that the BVH tests
// the very floats every other tracer tests. Runs when the hierarchy or the geometry changed.

#import bevy_rppm::common::row_texel
#import bevy_rppm::scene::triangle_at

// The triangle ids in leaf order (src/cubemap/bvh/build.rs's `indices`).
@group(1) @binding(0) var<storage, read> order: array<u32>;
@group(1) @binding(1) var corners: texture_storage_2d<rgba32float, write>;

@compute @workgroup_size(64)
fn fill(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    let k = (group.y * groups.x + group.x) * 64u + lane;
    if k >= arrayLength(&order) {
        return;
    }
    let id = order[k];
    let t = triangle_at(id);
    // Ids below 2^24 are exact as floats (the scene holds far fewer triangles).
    textureStore(corners, row_texel(3u * k), vec4<f32>(t.position_a, f32(id)));
    textureStore(corners, row_texel(3u * k + 1u), vec4<f32>(t.position_b, 0.0));
    textureStore(corners, row_texel(3u * k + 2u), vec4<f32>(t.position_c, 0.0));
}
