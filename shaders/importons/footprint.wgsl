// A pixel's footprint carried through smooth glass and mirrors by ray differentials (Igehy,
// "Tracing Ray Differentials", SIGGRAPH 1999): how far the surface a camera path meets moves
// per pixel. The path length alone misses a lens: a clear ball magnifies what lies under it,
// and an importon there gathered over a disc several times wider than its pixel sees, a
// caustic seen through the ball smeared out. Two differentials, for two orthogonal pixel
// steps (the pixel is as wide as it is high), started at a path's first bounce (most paths
// end at their first vertex and never need them).
#define_import_path bevy_rppm::footprint
#import bevy_rppm::common::Triangle

struct Footprint {
    // Position and direction per step along x and along y.
    px: vec3<f32>,
    dx: vec3<f32>,
    py: vec3<f32>,
    dy: vec3<f32>,
    // Every bounce since the camera was a mirror or a refraction (else the footprint is the
    // path length's and these are not read).
    delta: bool,
}

// The differentials of a ray the camera sends along `d` from the eye (`spread` a pixel's
// angle), or parallel to it from a pixel `spread` wide (orthographic).
fn footprint_from_camera(d: vec3<f32>, spread: f32, orthographic: bool) -> Footprint {
    let side = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(d.x) > 0.9);
    let u = normalize(cross(d, side)) * spread;
    let v = cross(d, u);
    if orthographic {
        return Footprint(u, vec3<f32>(0.0), v, vec3<f32>(0.0), true);
    }
    return Footprint(vec3<f32>(0.0), u, vec3<f32>(0.0), v, true);
}

// Moves one differential along d by t onto the plane of normal g.
fn onto_plane(p: vec3<f32>, dd: vec3<f32>, d: vec3<f32>, t: f32, g: vec3<f32>) -> vec3<f32> {
    let q = p + t * dd;
    return q - d * (dot(q, g) / dot(d, g));
}

// The footprint moved along `d` by `t` onto the triangle met there.
fn footprint_transfer(f: Footprint, d: vec3<f32>, t: f32, tri: Triangle) -> Footprint {
    var out = f;
    let g = cross(tri.position_b - tri.position_a, tri.position_c - tri.position_a);
    if !f.delta || abs(dot(d, g)) <= 1e-4 * length(g) {
        out.delta = false;
        return out;
    }
    out.px = onto_plane(f.px, f.dx, d, t, g);
    out.py = onto_plane(f.py, f.dy, d, t, g);
    return out;
}

// How the shading normal (interpolated over `tri`, facing `sign`) turns at point x along the
// steps px and py within the triangle: one barycentric setup for both.
fn normal_steps(tri: Triangle, x: vec3<f32>, px: vec3<f32>, py: vec3<f32>, sign: f32) -> array<vec3<f32>, 2> {
    let e1 = tri.position_b - tri.position_a;
    let e2 = tri.position_c - tri.position_a;
    let g = cross(e1, e2);
    let inv = 1.0 / dot(g, g);
    let r = x - tri.position_a;
    let b = vec2<f32>(dot(cross(r, e2), g), dot(cross(e1, r), g)) * inv;
    let n = tri.normal_a * (1.0 - b.x - b.y) + tri.normal_b * b.x + tri.normal_c * b.y;
    let k = 1.0 / max(length(n), 1e-12);
    let unit = n * k;
    var steps: array<vec3<f32>, 2>;
    let p = array<vec3<f32>, 2>(px, py);
    for (var i = 0; i < 2; i += 1) {
        let db = vec2<f32>(dot(cross(p[i], e2), g), dot(cross(e1, p[i]), g)) * inv;
        let dn = (tri.normal_b - tri.normal_a) * db.x + (tri.normal_c - tri.normal_a) * db.y;
        steps[i] = sign * (dn - unit * dot(unit, dn)) * k;
    }
    return steps;
}

// One differential's direction after the bounce from d to `out` at normal n (facing d's
// side): mirror reflection, or refraction with relative index eta.
fn bend(d: vec3<f32>, dd: vec3<f32>, out: vec3<f32>, n: vec3<f32>, dn: vec3<f32>, eta: f32, refracted: bool) -> vec3<f32> {
    let dn_d = dot(dd, n) + dot(d, dn);
    let d_n = dot(d, n);
    if !refracted {
        return dd - 2.0 * (d_n * dn + dn_d * n);
    }
    let out_n = dot(out, n);
    let mu = eta * d_n - out_n;
    let dmu = (eta - eta * eta * d_n / out_n) * dn_d;
    return eta * dd - (dmu * n + mu * dn);
}

// The footprint after the path at x (triangle `tri`, shading normal n facing d's side,
// `front`: the side the triangle faces) bounced from d to `out`: kept through a mirror
// reflection or a refraction with relative index eta, ended by anything else.
fn footprint_bounce(f: Footprint, tri: Triangle, x: vec3<f32>, n: vec3<f32>, front: bool, d: vec3<f32>, out: vec3<f32>, eta: f32) -> Footprint {
    var next = f;
    let reflected = dot(out, reflect(d, n)) > 0.9999;
    let through = refract(d, n, eta);
    let refracted = !reflected && any(through != vec3<f32>(0.0)) && dot(out, through) > 0.9999;
    if !f.delta || !(reflected || refracted) {
        next.delta = false;
        return next;
    }
    let dn = normal_steps(tri, x, f.px, f.py, select(-1.0, 1.0, front));
    next.dx = bend(d, f.dx, out, n, dn[0], eta, refracted);
    next.dy = bend(d, f.dy, out, n, dn[1], eta, refracted);
    return next;
}

// Most a lens may narrow a footprint below the path length's (at a focus it would reach 0,
// and an importon there would gather nothing).
const MOST_NARROWING: f32 = 8.0;

// The footprint's width across the ray `d` that reached it (the root mean square of the two
// steps), or `unfolded` (the path length's) where the path was not all mirrors and glass.
// Never wider than `unfolded`: a ball's minified view of the room behind it would gather
// over discs several times wider, and each from many more photons (`cornell_glass`'s
// indirect splat took 3× as long).
fn footprint_width(f: Footprint, d: vec3<f32>, unfolded: f32) -> f32 {
    if !f.delta {
        return unfolded;
    }
    let x = f.px - d * dot(f.px, d);
    let y = f.py - d * dot(f.py, d);
    let width = sqrt(0.5 * (dot(x, x) + dot(y, y)));
    if !(width == width) || width > 3.0e38 {
        return unfolded;
    }
    return clamp(width, unfolded / MOST_NARROWING, unfolded);
}
