// Edges through a camera move, reconstructed from their subpixels (Chajdas, McGuire and
// Luebke 2011, "Subpixel reconstruction antialiasing"). A frame whose camera moved rasterizes
// all its iterations at one jitter (src/graph/prepare.rs), so each pixel's history is of the
// one surface its sample meets, and an edge's pixel shows one side whole where a converged
// image shows each side by its coverage. Here an edge's pixel (one of its 3 × 3 sees another
// surface) traces eight rays through its footprint; each takes the pixel's own estimate where
// it meets the pixel's surface (whose light may vary within the pixel: a highlight), else the
// estimate of the nearest pixel of the 3 × 3 that sees what it met, and the pixel shows their
// mean. Other pixels show their estimate as it is. Only light already accumulated is moved:
// nothing here is kept for the next frame.
#import bevy_rppm::common::IterationParams
#import bevy_rppm::cubemap::camera_hit
#import bevy_rppm::surface::{neighbour, surface_marks, packed_surface, same_surface}

@group(1) @binding(0) var<uniform> params: IterationParams;
@group(2) @binding(0) var gbuffer_position: texture_2d<f32>;
@group(2) @binding(1) var gbuffer_normal: texture_2d<f32>;
@group(2) @binding(2) var<storage, read> radiance: array<vec4<f32>>;
@group(2) @binding(3) var<storage, read_write> shown: array<vec4<f32>>;

// Direct3D's standard 8× MSAA sample positions, in sixteenths of a pixel from its centre:
// stratified in x and y alike.
const SUBPIXELS = array<vec2<f32>, 8>(
    vec2<f32>(1.0, -3.0), vec2<f32>(-1.0, 3.0), vec2<f32>(5.0, 1.0), vec2<f32>(-3.0, -5.0),
    vec2<f32>(-5.0, 5.0), vec2<f32>(-7.0, -1.0), vec2<f32>(3.0, 7.0), vec2<f32>(7.0, -7.0),
);

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= params.size) {
        return;
    }
    let index = id.y * params.size.x + id.x;
    let own = radiance[index];
    let position = textureLoad(gbuffer_position, vec2<i32>(id.xy), 0);
    let normal = textureLoad(gbuffer_normal, vec2<i32>(id.xy), 0);
    let marks = surface_marks(position);
    // The block's surfaces as the history keeps them, and whether one is not this pixel's.
    var block: array<vec4<f32>, 9>;
    var edge = false;
    for (var k = 0; k < 9; k += 1) {
        let p = neighbour(params.size, id.xy, k);
        let q = textureLoad(gbuffer_position, p, 0);
        block[k] = packed_surface(q, textureLoad(gbuffer_normal, p, 0).xyz, surface_marks(q));
        edge = edge || !same_surface(params, block[k], position, normal, marks);
    }
    if !edge {
        shown[index] = own;
        return;
    }
    var sum = vec3<f32>(0.0);
    for (var s = 0u; s < 8u; s += 1u) {
        // The pixel's centre is `jitter` past its sample's, which the view's centre is.
        let m = camera_hit(params, vec2<f32>(id.xy) + 0.5 + params.jitter + SUBPIXELS[s] / 16.0);
        let met_marks = surface_marks(m[0]);
        // The pixel itself where it sees that surface, else the nearest pixel that sees it
        // (each history is of one surface: the frame's iterations shared one jitter).
        var chosen = 4;
        var nearest = select(1.0e30, -1.0, same_surface(params, block[4], m[0], m[1], met_marks));
        for (var k = 0; k < 9; k += 1) {
            let d = distance(block[k].xyz, m[0].xyz);
            if d < nearest && same_surface(params, block[k], m[0], m[1], met_marks) {
                chosen = k;
                nearest = d;
            }
        }
        let p = neighbour(params.size, id.xy, chosen);
        sum += radiance[u32(p.y) * params.size.x + u32(p.x)].rgb;
    }
    // The still frames after a move: their jittered iterations anti-alias the pixel too.
    shown[index] = vec4<f32>(mix(own.rgb, sum / 8.0, params.resolve_share), own.w);
}
