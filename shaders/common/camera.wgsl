// The camera's rays: through a pixel, and back toward the eye.

#define_import_path bevy_rppm::camera

#import bevy_rppm::common::IterationParams

struct CameraRay {
    origin: vec3<f32>,
    direction: vec3<f32>,
}

// The camera's ray through the centre of `pixel`, from the near plane. Reverse Z: clip depth 1
// is the near plane and 0.5 another point on the same ray, under either projection.
fn camera_ray(params: IterationParams, pixel: vec2<u32>) -> CameraRay {
    return camera_ray_at(params, vec2<f32>(pixel) + 0.5);
}

// The camera's ray through point `at` of the image (pixels, x right and y down).
fn camera_ray_at(params: IterationParams, at: vec2<f32>) -> CameraRay {
    let ndc = at / vec2<f32>(params.size) * vec2<f32>(2.0, -2.0) + vec2<f32>(-1.0, 1.0);
    let near = params.world_from_clip * vec4<f32>(ndc, 1.0, 1.0);
    let mid = params.world_from_clip * vec4<f32>(ndc, 0.5, 1.0);
    let origin = near.xyz / near.w;
    return CameraRay(origin, normalize(mid.xyz / mid.w - origin));
}

// The unit direction from `p` toward the eye: the view's back direction under an orthographic
// projection (its rays are parallel), which world_from_clip maps clip depth's axis to.
fn toward_eye(params: IterationParams, p: vec3<f32>) -> vec3<f32> {
    if params.orthographic != 0u {
        return normalize((params.world_from_clip * vec4<f32>(0.0, 0.0, 1.0, 0.0)).xyz);
    }
    return normalize(params.camera_position.xyz - p);
}

// Where `point` (w 0: a direction) lay in last frame's image (`previous_clip_from_world`), in
// pixels; z: 1 inside it.
fn previous_pixel(params: IterationParams, point: vec4<f32>) -> vec3<f32> {
    let clip = params.previous_clip_from_world * point;
    if clip.w <= 0.0 {
        return vec3<f32>(0.0);
    }
    let at = (vec2<f32>(0.5, -0.5) * clip.xy / clip.w + 0.5) * vec2<f32>(params.size);
    let inside = all(at >= vec2<f32>(0.0)) && all(at < vec2<f32>(params.size));
    return vec3<f32>(at, select(0.0, 1.0, inside));
}
