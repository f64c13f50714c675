#!/usr/bin/env python3
"""Random rooms the project was not built against, for finding where a render leaves its
reference: each draws a room (closed with the camera inside, or open at the front under a sky
and a sun), wall albedos from dark to bright, objects (boxes and spheres of diffuse, metal,
plastic, clear, frosted or tinted glass) and lights (point, sphere, spot, emissive panels).
A seed gives the same scenes on every machine. `--wide` adds mirrors, emissive boxes and balls
and windows with the sun; `--textured` adds checkered floors, normal-mapped walls, cut-out
screens (alpha-masked, double-sided) and dense spheres of ~10⁵ triangles.

    python3 tools/random_scenes.py out/random --count 12 --seed 1
    python3 tools/reference.py out/random/r1_00.gltf --out out/random/r1_00.ref.exr --width 128 --height 128 --spp 4096

Lights that glass refracts are spheres or panels (never points), and open rooms with glass
have no sun: a path-traced reference cannot find a point light or the sun through smooth
glass, so it would lack light that photon mapping renders.
"""
import argparse
import math
import os
import random
import shutil

from gltf_kit import Gltf, box, rotate_y, sphere

LIFT = 0.005  # objects float 5 mm over the floor: no coplanar contact


def colour(draw, lo, hi):
    """A colour whose channels lie in [lo, hi], tinted at random."""
    base = draw.uniform(lo, hi)
    return [min(hi, max(lo, base * draw.uniform(0.6, 1.25))) for _ in range(3)]


def object_material(g, draw, kind):
    if kind == "mirror":
        return g.material([0.95, 0.95, 0.95], roughness=draw.choice([0.0, draw.uniform(0.05, 0.15)]), metallic=1.0)
    if kind == "lamp":
        return g.emitter([1.0, draw.uniform(0.7, 1.0), draw.uniform(0.5, 0.9)], draw.uniform(5.0, 20.0))
    if kind == "diffuse":
        return g.material(colour(draw, 0.1, 0.85))
    if kind == "metal":
        tint = draw.choice([[0.95, 0.8, 0.45], [0.9, 0.9, 0.92], [0.95, 0.6, 0.5]])
        return g.material(tint, roughness=draw.uniform(0.15, 0.7), metallic=1.0)
    if kind == "plastic":
        return g.material(colour(draw, 0.1, 0.8), roughness=draw.uniform(0.25, 0.6))
    if kind == "glass":
        return g.glass(draw.uniform(1.33, 1.6))
    if kind == "frosted":
        return g.rough_glass(draw.uniform(1.33, 1.6), draw.uniform(0.25, 0.5))
    return g.tinted_glass(1.5, colour(draw, 0.2, 0.9), draw.uniform(0.2, 0.6))


def window_wall(x, h, d, draw):
    """The wall at x (facing +x, into the room) with a window hole: four quads around it."""
    y0, y1 = draw.uniform(0.6, 1.0), h - draw.uniform(0.3, 0.6)
    z0, z1 = -d / 2 + draw.uniform(0.3, d / 3), d / 2 - draw.uniform(0.3, d / 3)
    def quad(za, zb, ya, yb):
        return [[x, ya, za], [x, yb, za], [x, yb, zb], [x, ya, zb]]
    return [quad(-d / 2, z0, 0, h), quad(z1, d / 2, 0, h), quad(z0, z1, 0, y0), quad(z0, z1, y1, h)]


TEXTURES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "../assets/suite/textures")


def textured(g, draw, rgb):
    """A wall material of colour `rgb`: plain, or under a normal map of bumps or tiles."""
    if draw.random() < 0.5:
        return g.material(rgb), None
    normal = g.texture("textures/" + draw.choice(["bumps.png", "tiles.png"]))
    return g.material(rgb, normalTexture={"index": normal}), draw.uniform(0.3, 1.0)


def screen(g, draw, x, z, s):
    """A double-sided cut-out screen of round holes (alpha-masked), upright or flat, at (x, z)."""
    leaf = g.texture("textures/holes.png")
    material = g.material([1, 1, 1], roughness=1.0, alphaMode="MASK", alphaCutoff=0.5, doubleSided=True)
    g.materials[material]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": leaf}
    y = LIFT + draw.uniform(0.3, 1.0)
    if draw.random() < 0.5:
        quad = [[x - s, y + s, z], [x - s, y - s, z], [x + s, y - s, z], [x + s, y + s, z]][::-1]
        quad = rotate_y(quad, draw.uniform(0, math.pi), [x, 0, z])
    else:
        quad = [[x - s, y, z + s], [x + s, y, z + s], [x + s, y, z - s], [x - s, y, z - s]]
    g.quads([quad], material, uv_size=2 * s / draw.choice([1, 2]))


def scene(path, seed, wide=False, textures=False, coarse=False):
    """One room; `wide` also draws mirrors, emissive balls and a window with the sun in it;
    `textures` checkered floors, normal-mapped walls, cut-out screens and dense spheres
    (`coarse`: of as few triangles as the others, for small test assets)."""
    draw = random.Random(seed)
    w, h, d = draw.uniform(2.5, 5.0), draw.uniform(2.2, 3.4), draw.uniform(2.5, 5.0)
    closed = draw.random() < 0.5
    g = Gltf()
    faces = box([-w / 2, 0, -d / 2], [w / 2, h, d / 2], inward=True)
    floor, ceiling, back, front, left, right = faces
    floor_material = object_material(g, draw, draw.choice(["diffuse", "diffuse", "metal", "plastic"]))
    floor_uv = None
    if textures and draw.random() < 0.6:
        checker = g.texture("textures/checker.png")
        g.materials[floor_material]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": checker}
        floor_uv = draw.uniform(0.5, 2.0)
    g.quads([floor], floor_material, uv_size=floor_uv)
    walls = [(wall, colour(draw, 0.1, 0.85)) for wall in (ceiling, back, left, right) + ((front,) if closed else ())]
    kinds = ["diffuse", "metal", "plastic", "glass", "frosted", "tinted"] + (["mirror", "lamp"] if wide else [])
    kinds += ["screen", "dense", "screen"] if textures else []
    kinds = [draw.choice(kinds) for _ in range(draw.randint(1, 3))]
    has_glass = any(k in ("glass", "frosted", "tinted") for k in kinds)
    window = wide and closed and not has_glass and draw.random() < 0.5
    for wall, rgb in walls:
        material, uv = textured(g, draw, rgb) if textures else (g.material(rgb), None)
        g.quads(window_wall(-w / 2, h, d, draw) if window and wall is left else [wall], material, uv)

    slots = [(-w / 4, -d / 4), (w / 4, -d / 4), (0.0, d / 8)]
    draw.shuffle(slots)
    for kind, (x, z) in zip(kinds, slots):
        s = draw.uniform(0.2, 0.45)
        if kind == "screen":
            screen(g, draw, x, z, s * 1.5)
            continue
        if kind == "dense":
            # ~10⁵ triangles of diffuse or metal: many triangles per deep-cubemap pixel.
            rings = 24 if coarse else 180
            pos, nor, idx = sphere([x, LIFT + s, z], s, rings=rings, segments=2 * rings)
            g.mesh(pos, nor, idx, object_material(g, draw, draw.choice(["diffuse", "metal"])))
            continue
        material = object_material(g, draw, kind)
        if draw.random() < 0.5:
            pos, nor, idx = sphere([x, LIFT + s, z], s)
            g.mesh(pos, nor, idx, material)
        else:
            top = LIFT + s * draw.uniform(1.0, 3.0)
            cube = box([x - s, LIFT, z - s], [x + s, top, z + s], inward=False)
            angle = draw.uniform(0, math.pi / 2)
            g.quads([rotate_y(f, angle, [x, 0, z]) for f in cube], material)

    lights = draw.randint(1, 3)
    for _ in range(lights):
        kind = draw.choice(["point", "spot", "panel"])
        at = [draw.uniform(-w / 3, w / 3), h - draw.uniform(0.3, 0.8), draw.uniform(-d / 3, d / 4)]
        rgb = [1.0, draw.uniform(0.8, 1.0), draw.uniform(0.6, 1.0)]
        if kind == "panel":
            s = draw.uniform(0.15, 0.5)
            y = h - 0.01
            g.quads([[[at[0] - s, y, at[2] - s], [at[0] + s, y, at[2] - s], [at[0] + s, y, at[2] + s],
                      [at[0] - s, y, at[2] + s]]], g.emitter(rgb, draw.uniform(5.0, 30.0) * 0.1 / (s * s)))
        elif kind == "spot" and not has_glass:
            target = [draw.uniform(-w / 4, w / 4), 0.0, draw.uniform(-d / 4, d / 4)]
            outer = draw.uniform(0.3, 0.8)
            g.light({"type": "spot", "color": rgb, "intensity": draw.uniform(5.0, 30.0),
                     "spot": {"innerConeAngle": outer * draw.uniform(0.3, 0.9), "outerConeAngle": outer}},
                    translation=at, direction=[target[k] - at[k] for k in range(3)])
        else:
            light = {"type": "point", "color": rgb, "intensity": draw.uniform(2.0, 15.0)}
            if has_glass or draw.random() < 0.4:
                light["extras"] = {"rppm_radius": draw.uniform(0.05, 0.2)}
            g.light(light, translation=at)
    sky = None
    if window:
        # The sun through the window in the left wall, onto the floor; the sky outside it.
        sky = colour(draw, 0.1, 0.5)
        g.light({"type": "directional", "color": [1.0, 0.95, 0.85], "intensity": draw.uniform(2.0, 8.0)},
                direction=[draw.uniform(0.5, 1.0), -draw.uniform(0.3, 0.8), draw.uniform(-0.4, 0.4)])
    if not closed:
        if draw.random() < 0.5:
            sky = colour(draw, 0.1, 0.5)
        if not has_glass and draw.random() < 0.5:
            g.light({"type": "directional", "color": [1.0, 0.95, 0.85], "intensity": draw.uniform(1.0, 5.0)},
                    direction=[draw.uniform(-0.5, 0.5), -draw.uniform(0.4, 1.0), -draw.uniform(0.3, 1.0)])

    eye_z = d / 2 - 0.3 if closed else d / 2 + draw.uniform(0.0, 1.0)
    eye = [draw.uniform(-w / 4, w / 4), draw.uniform(1.0, h - 0.4), eye_z]
    g.camera(eye, [draw.uniform(-0.3, 0.3), draw.uniform(0.2, 0.8), -d / 4], yfov=draw.uniform(0.8, 1.1))
    g.write(path, f"bevy_rppm tools/random_scenes.py seed {seed}", sky=sky)
    return {"closed": closed, "objects": kinds, "lights": lights, "sky": sky is not None, "window": window}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", help="folder for the .gltf files")
    parser.add_argument("--count", type=int, default=12)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--wide", action="store_true", help="mirrors, emissive balls and windows too")
    parser.add_argument("--textured", action="store_true",
                        help="checkered floors, normal-mapped walls, cut-out screens and dense spheres too")
    parser.add_argument("--coarse", action="store_true",
                        help="dense spheres of as few triangles as the others (small test assets)")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    if args.textured:
        shutil.copytree(TEXTURES, os.path.join(args.out, "textures"), dirs_exist_ok=True)
    for i in range(args.count):
        path = os.path.join(args.out, f"r{args.seed}_{i:02}.gltf")
        print(path, scene(path, args.seed * 1000 + i, args.wide, args.textured, args.coarse))


if __name__ == "__main__":
    main()
