// Shadow maps: depth of every scene triangle seen from one shadow view. The view index arrives
// as the instance index, so one pipeline serves every light and face.
#import bevy_rppm::common::triangle_position
#import bevy_rppm::scene::{triangle_at, shadow_views}

@vertex
fn vertex(@builtin(vertex_index) vertex: u32, @builtin(instance_index) view: u32) -> @builtin(position) vec4<f32> {
    let t = triangle_at(vertex / 3u);
    return shadow_views[view].clip_from_world * vec4<f32>(triangle_position(t, vertex % 3u), 1.0);
}
