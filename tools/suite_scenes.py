#!/usr/bin/env python3
"""Suite scenes the renderer was not tuned on (assets/suite/README.md), each aimed at one class
of failure:

- `sun_room`: a closed room with dark walls (albedo 0.12–0.2) and one-sided faces, lit only by
  a directional sun through a window in one wall, the camera inside;
- `glazed_room`: `sun_room`'s room with its window double-glazed (two 4 mm panes of clear
  glass), lit through it by the sun, a sky and a spot light outside; the camera looks away
  from the window (reference by light tracing);
- `glass_slab`: a flat-faced glass block (ior 1.5, one-sided faces) 5 mm over the floor of an
  open box, under a small bright emissive panel: its caustic and total internal reflection;
- `tinted_glass`: two blocks of coloured glass (`KHR_materials_volume`: absorption along the
  path inside) on the floor of an open box under a panel: coloured caustics and shadows;
- `frosted_glass`: a standing pane of rough glass (roughness 0.4) with a red block seen
  blurred behind it, and a lightly rough glass block (0.15) under a panel;
- `frosted_lamp`: a point light behind a frosted pane (seen through it as a glow) and a small
  lamp panel reflected in a brushed metal plate: light found through rough lobes;
- `frosted_lantern`: a point light inside a hollow frosted glass lantern (roughness 0.2) and a
  spot light behind a frosted pane of ior 1.33 (roughness 0.5): punctual lights seen through
  two rough interfaces, of other roughnesses, indices and light kinds than `frosted_lamp`'s;
- `water_pool`: a static water height field (ior 1.33) in a tiled pool under a large sky quad;
- `sky_court`: a yard open to a uniform blue sky (`scenes[0].extras.rppm_sky`), red walls in a
  corner, a glass block and a white box;
- `lens_caustic`: a glass ball under a point light, both above the camera's view, focusing
  the light into a caustic on the floor of an open box (reference by light tracing:
  `reference.py --integrator ptracer`);
- `clearcoat`: clearcoats over Lambertian paint: a lacquered floor (a mirror coat), a red
  ball under a smooth coat and a teal block under a satin one (reference with
  `tools/bevy_layers.py`'s `bevy_coat`);
- `translucent`: diffuse transmission: a paper screen and a lamp shade, each with a point
  light behind or inside it (reference with `bevy_translucent`);
- `mirror_caustic`: a glass ball's caustic under a panel, seen again in a mirror wall, and a
  spot light clear of both;
- `sun_spot_caustics`: caustics from a directional sun and a spot light, each through a glass
  ball above the camera's view (reference by light tracing, as `lens_caustic`'s);
- `lamp_globe`: a point light inside a closed globe of frosted glass above the camera's view,
  the only light: every path from it crosses two rough interfaces, and no shadow ray reaches
  it (reference by light tracing);
- `studio`: a small set (floor, backdrop, a glass block and a glass ball, a red box) under a
  tilted softbox panel 7× its floor's area, in open space: most of the panel's hemisphere
  meets nothing, and the glass reflects the panel;
- `many_lights`: a room lit by 24 coloured point lights under its ceiling and 4 spot lights,
  more than a vertex samples (8, drawn by power), with a gold block at roughness 0.3 (the
  rough end of issue 11's glossy metals) reflecting the lit ceiling, and a matte block.

With `--tests`, it writes instead the scenes only tests use (kept in `assets/suite/random/`):

- `lamp_by_pane`: a glowing ball on the floor of an open box, a clear pane standing beside
  it: the floor sees the ball up close, directly and through the pane.

    python3 tools/suite_scenes.py assets/suite
    python3 tools/suite_scenes.py assets/suite/random --tests
    python3 tools/reference.py assets/suite/sun_room.gltf --out assets/suite/sun_room.ref.exr \
        --width 128 --height 128 --spp 2048 --variant scalar_rgb
"""
import argparse
import math
import os
import random

from gltf_kit import Gltf, box, ceiling_panel, coloured_walls, inward, open_box, rotate_y, sphere, unit

# The air gap under every glass object standing on a floor (and the metal plate in
# frosted_lamp): a face coplanar with the floor is a contact renderers read differently
# (assets/suite/README.md).
LIFT = 0.005


def window_room(g):
    """sun_room's room: dark walls (one-sided), a grey block on the floor, and in the left wall
    (x = −2, facing +x) a window; returns the opening (x, z0, z1, y0, y1)."""
    w, h, d = 4.0, 3.0, 4.0
    x0, x1, z0, z1 = -w / 2, w / 2, -d / 2, d / 2
    floor, ceiling, back, front, _left, right = box([x0, 0, z0], [x1, h, z1], inward=True)
    g.quads([floor], g.material([0.5, 0.45, 0.4]))
    g.quads([ceiling, front], g.material([0.18, 0.18, 0.18]))
    g.quads([back], g.material([0.2, 0.12, 0.1]))
    g.quads([right], g.material([0.1, 0.15, 0.12]))
    wz0, wz1, wy0, wy1 = -0.9, 0.7, 1.0, 2.3
    wall = g.material([0.15, 0.15, 0.18])

    def panel(za, zb, ya, yb):
        return [[x0, ya, za], [x0, yb, za], [x0, yb, zb], [x0, ya, zb]]
    g.quads([panel(z0, wz0, 0, h), panel(wz1, z1, 0, h), panel(wz0, wz1, 0, wy0), panel(wz0, wz1, wy1, h)], wall)
    # A grey block on the floor in the sunlit patch.
    g.quads([rotate_y(f, 0.4, [0.2, 0, 0.0]) for f in box([-0.1, 0, -0.3], [0.5, 0.6, 0.3], inward=False)],
            g.material([0.5, 0.5, 0.5]))
    return x0, wz0, wz1, wy0, wy1


def sun_room(path):
    g = Gltf()
    window_room(g)
    g.light({"type": "directional", "color": [1.0, 0.95, 0.85], "intensity": 6.0}, direction=[0.75, -0.55, 0.1])
    g.camera([1.6, 1.7, 1.8], [-1.2, 0.6, -0.7])
    g.write(path, "bevy_rppm tools/suite_scenes.py sun_room")


def glazed_room(path):
    g = Gltf()
    x0, wz0, wz1, wy0, wy1 = window_room(g)
    # Double glazing: two 4 mm panes of clear glass (ior 1.5) 12 mm apart fill the window.
    glass = g.glass(1.5)
    for outer in (x0, x0 - 0.016):
        g.quads(box([outer - 0.004, wy0, wz0], [outer, wy1, wz1], inward=False), glass)
    g.light({"type": "directional", "color": [1.0, 0.95, 0.85], "intensity": 6.0}, direction=[0.75, -0.55, 0.3])
    # A lamp outside, 1.2 m from the window, shines in past the sun's patch.
    g.light({"type": "spot", "color": [1.0, 0.9, 0.8], "intensity": 30.0,
             "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.45}},
            translation=[-3.2, 2.6, 0.0], direction=[0.8, -0.55, -0.05])
    # The camera looks away from the window (what it shows, light tracing cannot render).
    g.camera([-1.5, 1.6, 1.8], [1.0, 0.3, -1.0])
    g.write(path, "bevy_rppm tools/suite_scenes.py glazed_room", sky=[0.25, 0.32, 0.45])


def glass_slab(path):
    g, h, faces = open_box()
    coloured_walls(g, faces, [0.7, 0.7, 0.68], [0.65, 0.2, 0.15], [0.2, 0.3, 0.65])
    # A glass block on the floor, turned 25° about y, over the air gap LIFT.
    faces = [rotate_y(f, 0.44, [0.1, 0, -0.2]) for f in box([-0.45, LIFT, -0.45], [0.65, 0.35 + LIFT, 0.05], inward=False)]
    g.quads(faces, g.glass(1.5))
    # A small panel facing down, above and behind the block, 0.4 m square.
    ceiling_panel(g, h - 0.01, -0.4, -0.8, 0.2, [1.0, 0.9, 0.75], 40.0)
    g.camera([0.0, 1.5, 2.9], [0.0, 0.3, -0.4], yfov=0.8)
    g.write(path, "bevy_rppm tools/suite_scenes.py glass_slab")


def tinted_glass(path):
    g, h, faces = open_box()
    g.quads([f for k, f in enumerate(faces) if k != 3], g.material([0.75, 0.75, 0.72]))  # all but the open front
    # A green slab lying flat and an amber block standing, both absorbing along their paths
    # (their colour comes from the length light travels inside, not from their surfaces).
    # 5 mm above the floor: glass resting on a surface is an ambiguous contact (coplanar faces
    # that renderers order differently); a thin air gap is not.
    g.quads([rotate_y(f, -0.3, [-0.5, 0, 0.0]) for f in box([-1.0, LIFT, -0.4], [0.0, 0.25, 0.4], inward=False)],
            g.tinted_glass(1.5, [0.25, 0.75, 0.35], 0.25))
    g.quads([rotate_y(f, 0.5, [0.7, 0, -0.5]) for f in box([0.45, LIFT, -0.75], [0.95, 0.9, -0.25], inward=False)],
            g.tinted_glass(1.5, [0.9, 0.55, 0.15], 0.3))
    ceiling_panel(g, h - 0.01, 0.0, -0.6, 0.3, [1.0, 0.95, 0.9], 20.0)
    g.camera([0.0, 1.6, 2.9], [0.0, 0.3, -0.4], yfov=0.8)
    g.write(path, "bevy_rppm tools/suite_scenes.py tinted_glass")


def frosted_glass(path):
    g, h, faces = open_box()
    coloured_walls(g, faces, [0.7, 0.7, 0.68], [0.2, 0.55, 0.25], [0.25, 0.3, 0.7])
    # A red block behind a standing frosted pane (roughness 0.4, 4 cm thick): seen blurred
    # through it; and a lightly rough glass block (0.15) on the floor under the panel.
    g.quads([rotate_y(f, 0.3, [-0.5, 0, -0.6]) for f in box([-0.8, 0, -0.9], [-0.2, 0.6, -0.3], inward=False)],
            g.material([0.7, 0.15, 0.1]))
    g.quads([rotate_y(f, 0.15, [-0.4, 0, 0.0]) for f in box([-1.1, LIFT, -0.02], [0.3, 1.1, 0.02], inward=False)],
            g.rough_glass(1.5, 0.4))
    g.quads([rotate_y(f, -0.4, [0.75, 0, -0.2]) for f in box([0.4, LIFT, -0.55], [1.1, 0.35, 0.15], inward=False)],
            g.rough_glass(1.5, 0.15))
    ceiling_panel(g, h - 0.01, 0.2, -0.3, 0.5, [1.0, 0.95, 0.9], 8.0)
    g.camera([0.2, 1.5, 2.9], [-0.1, 0.4, -0.4], yfov=0.8)
    g.write(path, "bevy_rppm tools/suite_scenes.py frosted_glass")


def frosted_lamp(path):
    g, h, faces = open_box()
    coloured_walls(g, faces, [0.6, 0.6, 0.58], [0.6, 0.3, 0.15], [0.2, 0.4, 0.5])
    # A point light behind a standing frosted pane (roughness 0.3, 3 cm thick), seen through it
    # as a glow; a brushed metal plate (roughness 0.2) on the floor reflecting a small lamp
    # panel on the back wall.
    g.quads([rotate_y(f, -0.2, [-0.45, 0, -0.6]) for f in box([-1.1, LIFT, -0.615], [0.2, 1.1, -0.585], inward=False)],
            g.rough_glass(1.5, 0.3))
    g.light({"type": "point", "color": [1.0, 0.9, 0.75], "intensity": 2.0}, translation=[-0.45, 0.7, -1.0])
    g.quads(box([0.05, LIFT, 0.6], [0.95, 0.02, 1.4], inward=False), g.material([0.9, 0.85, 0.8], roughness=0.2, metallic=1.0))
    g.quads([[[0.8, 1.6, -1.49], [1.2, 1.6, -1.49], [1.2, 2.0, -1.49], [0.8, 2.0, -1.49]]], g.emitter([1.0, 0.95, 0.9], 12.0))
    g.camera([0.0, 1.3, 2.8], [0.0, 0.5, -0.3], yfov=0.9)
    g.write(path, "bevy_rppm tools/suite_scenes.py frosted_lamp")


def frosted_lantern(path):
    g, h, faces = open_box()
    coloured_walls(g, faces, [0.55, 0.55, 0.53], [0.2, 0.45, 0.3], [0.6, 0.55, 0.2])
    # A hollow lantern of frosted glass (roughness 0.2, walls 1 cm) on the floor with a small
    # sphere light inside it: seen through two rough interfaces, it lights the room through them.
    lo, hi, wall = [-0.55, LIFT, -0.5], [-0.1, 0.5, -0.05], 0.01
    lantern = g.rough_glass(1.5, 0.2)
    g.quads(box(lo, hi, inward=False), lantern)
    g.quads(box([c + wall for c in lo], [c - wall for c in hi], inward=True), lantern)
    g.light({"type": "point", "color": [1.0, 0.8, 0.55], "intensity": 1.5, "extras": {"rppm_radius": 0.03}},
            translation=[(lo[0] + hi[0]) / 2, 0.25, (lo[2] + hi[2]) / 2])
    # A standing pane of frosted water-glass (ior 1.33, roughness 0.5, 5 mm) with a spot light
    # behind it aimed through it at the room.
    g.quads([rotate_y(f, 0.3, [0.85, 0, -0.9]) for f in box([0.45, LIFT, -0.9], [1.25, 1.4, -0.895], inward=False)],
            g.rough_glass(1.33, 0.5))
    g.light({"type": "spot", "color": [0.8, 0.9, 1.0], "intensity": 4.0,
             "spot": {"innerConeAngle": 0.4, "outerConeAngle": 0.5}},
            translation=[0.95, 0.9, -1.3], direction=[-0.25, -0.35, 1.0])
    g.camera([0.1, 1.25, 2.8], [0.15, 0.45, -0.6], yfov=0.85)
    g.write(path, "bevy_rppm tools/suite_scenes.py frosted_lantern")


def water_pool(path):
    g = Gltf()
    half, depth, cells = 1.5, 0.8, 24
    light_tile, dark_tile = g.material([0.85, 0.87, 0.9]), g.material([0.2, 0.45, 0.7])
    for colour, parity in ((light_tile, 0), (dark_tile, 1)):
        quads = []
        n = 6
        step = 2 * half / n
        for i in range(n):
            for j in range(n):
                if (i + j) % 2 == parity:
                    xa, za = -half + step * i, -half + step * j
                    quads.append([[xa, -depth, za], [xa, -depth, za + step], [xa + step, -depth, za + step],
                                  [xa + step, -depth, za]])
        g.quads(quads, colour)
    _bottom, _top, back, front, left, right = box([-half, -depth, -half], [half, 0.1, half], inward=True)
    g.quads([back, front, left, right], g.material([0.6, 0.6, 0.55]))
    # Water: height 0 plus two crossing waves, smooth normals from the analytic slope.
    waves = [(0.05, 2.3, 0.0), (0.035, 0.9, 2.9)]
    n = cells + 1
    step = 2 * half / cells
    pos, nor, idx = [], [], []
    for k in range(n * n):
        x, z = -half + step * (k % n), -half + step * (k // n)
        hgt = sum(a * math.sin(kx * x + kz * z) for a, kx, kz in waves)
        dx = sum(a * kx * math.cos(kx * x + kz * z) for a, kx, kz in waves)
        dz = sum(a * kz * math.cos(kx * x + kz * z) for a, kx, kz in waves)
        pos.append([x, -0.1 + hgt, z])
        nor.append(unit([-dx, 1.0, -dz]))
    for j in range(cells):
        for i in range(cells):
            a = j * n + i
            idx += [a, a + n, a + 1, a + 1, a + n, a + n + 1]
    g.mesh(pos, nor, idx, g.glass(1.33))
    # The sky: a large quad facing down.
    s, y = 4.0, 3.0
    g.quads([[[-s, y, -s], [s, y, -s], [s, y, s], [-s, y, s]]], g.emitter([0.8, 0.9, 1.0], 2.0))
    g.camera([0.0, 2.2, 2.9], [0.0, -0.6, -0.2], yfov=0.8)
    g.write(path, "bevy_rppm tools/suite_scenes.py water_pool")


def lens_caustic(path):
    g, h, faces = open_box()
    coloured_walls(g, faces, [0.7, 0.7, 0.68], [0.65, 0.2, 0.15], [0.2, 0.3, 0.65])
    # A glass ball (ior 1.5) under a point light near its focal length: a bright caustic on
    # the floor, inside the ball's shadow. Both hang above the camera's view (all it sees lies
    # below y = 1.5 and is diffuse), so light tracing (Mitsuba's `ptracer`) renders every
    # path there is, while a path tracer cannot find a point light through glass at all.
    g.mesh(*sphere([0.2, 1.85, -0.6], 0.2), g.glass(1.5))
    g.light({"type": "point", "color": [1.0, 0.95, 0.9], "intensity": 8.0}, translation=[0.2, 2.35, -0.6])
    g.camera([0.0, 1.5, 2.9], [0.0, 0.0, -0.6], yfov=0.8)
    g.write(path, "bevy_rppm tools/suite_scenes.py lens_caustic")


def coated(strength, roughness):
    return {"KHR_materials_clearcoat": {"clearcoatFactor": strength, "clearcoatRoughnessFactor": roughness}}


def clearcoat(path):
    g, h, faces = open_box()
    floor, ceiling, back, _front, left, right = faces
    # Clearcoats over Lambertian paint (issue 12): a lacquered floor (a mirror coat, which
    # camera paths follow from the first hit), a red ball under a smooth coat (0.1, followed
    # too) and a teal block under a half-strength satin coat (0.5, gathered with the rest).
    g.quads([floor], g.material([0.45, 0.28, 0.15], extensions=coated(1.0, 0.0)))
    g.quads([ceiling, back], g.material([0.7, 0.7, 0.68]))
    g.quads([left], g.material([0.65, 0.2, 0.15]))
    g.quads([right], g.material([0.2, 0.3, 0.65]))
    g.mesh(*sphere([-0.55, 0.45, -0.45], 0.45), g.material([0.6, 0.05, 0.05], extensions=coated(1.0, 0.1)))
    g.quads([rotate_y(f, 0.4, [0.7, 0, -0.6]) for f in box([0.35, 0, -0.95], [1.05, 0.8, -0.25], inward=False)],
            g.material([0.1, 0.35, 0.3], extensions=coated(0.5, 0.5)))
    ceiling_panel(g, h - 0.01, 0.0, -0.3, 0.4, [1.0, 0.95, 0.9], 12.0)
    g.light({"type": "point", "color": [1.0, 0.95, 0.9], "intensity": 3.0}, translation=[0.9, 1.9, 0.6])
    g.camera([0.0, 1.4, 2.9], [0.0, 0.35, -0.5], yfov=0.8)
    g.write(path, "bevy_rppm tools/suite_scenes.py clearcoat")


def translucent(path):
    g, h, faces = open_box()
    coloured_walls(g, faces, [0.7, 0.7, 0.68], [0.65, 0.2, 0.15], [0.2, 0.3, 0.65])
    # Diffuse transmission (issue 12), lit only through it: a standing paper screen (one
    # double-sided quad, half its diffuse light through) with a point light behind it, and a
    # lamp: a closed one-sided box of warm shade (70 % through) around a point light,
    # hanging from the ceiling. Bevy's glTF loader does not read the extension; rppm does.
    def paper(rgb, share):
        return g.material(rgb, doubleSided=True, extensions={
            "KHR_materials_diffuse_transmission": {"diffuseTransmissionFactor": share}})
    screen = [[-1.2, 0.0, -0.3], [-0.1, 0.0, -0.5], [-0.1, 1.3, -0.5], [-1.2, 1.3, -0.3]]
    g.quads([screen], paper([0.8, 0.78, 0.7], 0.5))
    g.light({"type": "point", "color": [1.0, 0.9, 0.75], "intensity": 3.0}, translation=[-0.7, 0.8, -0.9])
    shade = g.material([0.9, 0.7, 0.45], extensions={
        "KHR_materials_diffuse_transmission": {"diffuseTransmissionFactor": 0.7}})
    g.quads(box([0.45, 1.2, -0.6], [0.95, 1.7, -0.1], inward=False), shade)
    g.light({"type": "point", "color": [1.0, 0.95, 0.9], "intensity": 4.0}, translation=[0.7, 1.45, -0.35])
    g.camera([0.0, 1.4, 2.9], [0.0, 0.6, -0.4], yfov=0.8)
    g.write(path, "bevy_rppm tools/suite_scenes.py translucent")


def sky_court(path):
    g = Gltf()
    # A grey yard open to a blue sky, two red walls meeting in a corner (one-sided, facing
    # the yard), a glass block and a white box; the camera sees the sky over the walls.
    half = 3.0
    floor, _ceiling, back, _front, left, _right = box([-half, 0, -half], [half, 1.6, half], inward=True)
    g.quads([floor], g.material([0.45, 0.45, 0.42]))
    g.quads([back, left], g.material([0.6, 0.15, 0.1]))
    g.quads([rotate_y(f, 0.5, [0.3, 0, 0.2]) for f in box([-0.2, LIFT, -0.3], [0.8, 0.5 + LIFT, 0.7], inward=False)],
            g.glass(1.5))
    g.quads([rotate_y(f, -0.3, [-1.5, 0, -1.2]) for f in box([-2.1, 0, -1.8], [-0.9, 0.9, -0.6], inward=False)],
            g.material([0.75, 0.75, 0.75]))
    g.camera([2.4, 2.2, 3.4], [-0.6, 0.5, -1.2], yfov=0.9)
    g.write(path, "bevy_rppm tools/suite_scenes.py sky_court", sky=[0.5, 0.65, 0.9])


def mirror_caustic(path):
    g, h, faces = open_box()
    floor, ceiling, back, _front, left, right = faces
    g.quads([floor, ceiling, back], g.material([0.7, 0.7, 0.68]))
    g.quads([left], g.material([0.65, 0.2, 0.15]))
    # The right wall a perfect mirror (metallic 1, roughness 0; one-sided): the camera sees the
    # glass ball's caustic twice, on the floor and in the mirror (camera paths through a
    # specular bounce before the surface that gathers).
    g.quads([right], g.material([0.92, 0.92, 0.9], roughness=0.0, metallic=1.0))
    # A glass ball (ior 1.5) 5 mm above the floor under a ceiling panel: its caustic lies in
    # its shadow, and the mirror shows both again.
    g.mesh(*sphere([0.55, 0.285, -0.45], 0.28), g.glass(1.5))
    ceiling_panel(g, h - 0.01, 0.55, -0.45, 0.25, [1.0, 0.95, 0.9], 15.0)
    # A spot light on the back-left corner, its cone clear of the glass and the mirror (a path
    # tracer cannot find a spot's caustic or its image in a mirror).
    g.light({"type": "spot", "color": [0.9, 0.95, 1.0], "intensity": 6.0,
             "spot": {"innerConeAngle": 0.33, "outerConeAngle": 0.35}},
            translation=[-0.9, 2.3, 0.4], direction=[-0.35, -1.0, -0.8])
    g.camera([-0.6, 1.45, 2.85], [0.75, 0.3, -0.6], yfov=0.85)
    g.write(path, "bevy_rppm tools/suite_scenes.py mirror_caustic")


def sun_spot_caustics(path):
    g = Gltf()
    # An open-topped box (no ceiling, no front) in the sun: a directional light and a spot light
    # each focus a caustic through a glass ball (ior 1.5) onto the floor. Both balls hang above
    # all the camera sees, which is diffuse, so light tracing (Mitsuba's `ptracer`) renders
    # every path there is; a path tracer cannot find a sun's or a spot's caustic at all.
    w, h, d = 3.0, 2.4, 3.0
    floor, _ceiling, back, _front, left, right = box([-w / 2, 0, -d / 2], [w / 2, h, d / 2], inward=True)
    g.quads([floor, back], g.material([0.7, 0.7, 0.68]))
    g.quads([left], g.material([0.65, 0.2, 0.15]))
    g.quads([right], g.material([0.2, 0.3, 0.65]))
    glass = g.glass(1.5)
    g.mesh(*sphere([-0.5, 1.9, -0.6], 0.2), glass)
    g.mesh(*sphere([0.6, 1.75, -0.3], 0.2), glass)
    # The sun from above, a little from the left and front; the spot straight down, its cone
    # wider than the ball, from 0.45 m above it.
    g.light({"type": "directional", "color": [1.0, 0.95, 0.85], "intensity": 2.0}, direction=[0.15, -1.0, -0.1])
    g.light({"type": "spot", "color": [0.85, 0.9, 1.0], "intensity": 6.0,
             "spot": {"innerConeAngle": 0.45, "outerConeAngle": 0.55}},
            translation=[0.6, 2.2, -0.3], direction=[0.0, -1.0, 0.0])
    g.camera([0.0, 1.3, 2.9], [0.0, 0.0, -0.5], yfov=0.8)
    g.write(path, "bevy_rppm tools/suite_scenes.py sun_spot_caustics")


def lamp_globe(path):
    g, h, faces = open_box()
    coloured_walls(g, faces, [0.6, 0.6, 0.58], [0.6, 0.25, 0.15], [0.2, 0.35, 0.6])
    # A hollow globe of frosted glass (roughness 0.3, walls 1 cm) hanging above all the camera
    # sees, with a point light inside it off its centre: the room is lit only through two
    # rough interfaces, which photons cross and shadow rays cannot.
    centre, glass = [0.3, 1.9, -0.5], g.rough_glass(1.5, 0.3)
    g.mesh(*sphere(centre, 0.18), glass)
    g.mesh(*inward(sphere(centre, 0.17)), glass)
    g.light({"type": "point", "color": [1.0, 0.92, 0.8], "intensity": 5.0}, translation=[0.33, 1.88, -0.48])
    g.quads([rotate_y(f, 0.5, [-0.4, 0, -0.3]) for f in box([-0.7, 0, -0.6], [-0.1, 0.5, 0.0], inward=False)],
            g.material([0.7, 0.7, 0.7]))
    g.camera([0.0, 1.3, 2.9], [0.0, 0.2, -0.5], yfov=0.8)
    g.write(path, "bevy_rppm tools/suite_scenes.py lamp_globe")


def studio(path):
    g = Gltf()
    floor = [[-1.0, 0.0, -0.8], [-1.0, 0.0, 0.8], [1.0, 0.0, 0.8], [1.0, 0.0, -0.8]]
    backdrop = [[-1.0, 0.0, -0.8], [1.0, 0.0, -0.8], [1.0, 1.2, -0.8], [-1.0, 1.2, -0.8]]
    g.quads([floor, backdrop], g.material([0.55, 0.55, 0.52]))
    lift = 0.005
    block = box([-0.7, lift, -0.45], [-0.2, 0.45 + lift, -0.05], inward=False)
    g.quads(block, g.glass(1.5))
    g.mesh(*sphere([0.35, 0.25 + lift, 0.15], 0.25), g.glass(1.5))
    red = box([0.1, 0.0, -0.6], [0.5, 0.3, -0.35], inward=False)
    g.quads(red[1:], g.material([0.7, 0.12, 0.1]))
    # The softbox: 4 m × 3 m, 2.5 m up, tilted 20° toward the set, facing down.
    c, s = 0.9397, 0.3420
    corners = [(-2.0, -1.5), (2.0, -1.5), (2.0, 1.5), (-2.0, 1.5)]
    panel = [[x, 2.5 - s * z, 1.0 + c * z] for x, z in corners]
    g.quads([panel], g.emitter([1.0, 0.97, 0.92], 3.0))
    g.camera([0.2, 1.1, 2.2], [-0.05, 0.25, -0.3], yfov=0.8)
    g.write(path, "bevy_rppm tools/suite_scenes.py studio")


def many_lights(path):
    g, h, faces = open_box()
    coloured_walls(g, faces, [0.6, 0.6, 0.58], [0.6, 0.2, 0.15], [0.15, 0.3, 0.6])
    g.quads(box([-0.9, 0, -1.0], [-0.3, 0.9, -0.4], inward=False), g.material([0.7, 0.7, 0.65]))
    g.quads(box([0.3, 0, -0.6], [0.9, 0.45, 0.0], inward=False), g.material([0.9, 0.8, 0.5], roughness=0.3, metallic=1.0))
    # 24 point lights of varied colour and power in a grid under the ceiling (a fixed random
    # draw), each lighting a spot of it that the gold block reflects; 4 spots at the walls.
    draw = random.Random(3)
    for i in range(24):
        x, z = -1.2 + 2.4 * (i % 6) / 5, -1.2 + 2.0 * (i // 6) / 3
        colour = [draw.uniform(0.3, 1.0) for _ in range(3)]
        g.light({"type": "point", "color": colour, "intensity": draw.uniform(0.05, 0.6)},
                translation=[x, draw.uniform(1.6, 2.2), z])
    spots = [([-1.3, 1.8, 0.5], [1, -1, -1]), ([1.3, 1.8, 0.5], [-1, -1, -1]),
             ([0.0, 2.2, -1.3], [0, -1, 0.3]), ([0.0, 0.4, 1.0], [0, 0.2, -1])]
    for position, direction in spots:
        g.light({"type": "spot", "color": [1.0, 0.9, 0.8], "intensity": 2.0,
                 "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.45}}, translation=position, direction=direction)
    g.camera([0.0, 1.3, 2.9], [0.0, 0.7, -0.5], yfov=0.85)
    g.write(path, "bevy_rppm tools/suite_scenes.py many_lights")


def lamp_by_pane(path):
    g, _, faces = open_box()
    coloured_walls(g, faces, [0.6, 0.6, 0.58], [0.6, 0.25, 0.15], [0.2, 0.35, 0.6])
    g.mesh(*sphere([-0.1, 0.255, -0.3], 0.25), g.emitter([1.0, 0.8, 0.55], 6.0))
    g.quads(box([0.2, 0.005, -0.7], [0.22, 0.6, 0.1], inward=False), g.glass(1.5))
    g.light({"type": "point", "color": [1.0, 0.95, 0.9], "intensity": 2.0}, translation=[0.5, 2.0, 0.5])
    g.camera([0.9, 0.9, 1.3], [0.0, 0.1, -0.3], yfov=0.8)
    g.write(path, "bevy_rppm tools/suite_scenes.py lamp_by_pane")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", help="folder for the .gltf files")
    parser.add_argument("--tests", action="store_true", help="the scenes only tests use instead")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    suite = (sun_room, glazed_room, glass_slab, tinted_glass, frosted_glass, frosted_lamp, frosted_lantern, water_pool, sky_court, lens_caustic, clearcoat, translucent,
             mirror_caustic, sun_spot_caustics, lamp_globe, studio, many_lights)
    for make in (lamp_by_pane,) if args.tests else suite:
        path = os.path.join(args.out, f"{make.__name__}.gltf")
        make(path)
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
