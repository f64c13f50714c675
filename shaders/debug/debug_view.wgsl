// Debug images: shading normals of the camera G-buffer, or of primary rays traced through the
// deep cubemap with the same jitter, as this iteration's sample. The two should match.
#import bevy_rppm::common::{IterationParams, triangle_normal}
#import bevy_rppm::camera::camera_ray
#import bevy_rppm::scene::{triangle_at, interpolated_normal}
#import bevy_rppm::cubemap::{trace_cubemap, NO_HIT}

@group(1) @binding(0) var<uniform> params: IterationParams;

@group(2) @binding(0) var gbuffer_position: texture_2d<f32>;
@group(2) @binding(1) var gbuffer_normal: texture_2d<f32>;
@group(2) @binding(3) var<storage, read_write> samples: array<vec4<f32>>;

fn accumulate(id: vec2<u32>, sample: vec3<f32>) {
    samples[id.y * params.size.x + id.x] = vec4<f32>(sample, 1.0);
}

@compute @workgroup_size(8, 8, 1)
fn gbuffer_normals(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= params.size) {
        return;
    }
    let pixel = vec2<i32>(id.xy);
    var sample = vec3<f32>(0.0);
    if textureLoad(gbuffer_position, pixel, 0).w != 0.0 {
        sample = textureLoad(gbuffer_normal, pixel, 0).xyz * 0.5 + 0.5;
    }
    accumulate(id.xy, sample);
}

@compute @workgroup_size(8, 8, 1)
fn cubemap_normals(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= params.size) {
        return;
    }
    let ray = camera_ray(params, id.xy);
    let o = ray.origin;
    let d = ray.direction;
    let hit = trace_cubemap(o, d, 0.0, 1.0e30, NO_HIT);
    var sample = vec3<f32>(0.0);
    if hit.triangle != NO_HIT {
        let t = triangle_at(hit.triangle);
        var n = interpolated_normal(t, hit.uv);
        // As the G-buffer: seen from behind its winding, the normal faces the camera.
        if dot(cross(t.position_b - t.position_a, t.position_c - t.position_a), d) > 0.0 {
            n = -n;
        }
        sample = n * 0.5 + 0.5;
    }
    accumulate(id.xy, sample);
}
