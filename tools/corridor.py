#!/usr/bin/env python3
"""A probe of depth: a closed corridor 2 m wide and 18 m long (one-sided walls facing in, each
wall one big quad), the camera inside at one end looking down it, three point lights of other
colours along it and a glass ball (ior 1.5) under the farthest, whose caustic lies 15 m from
the camera. Surfaces are seen from 0.5 to 18 m, many at grazing angles; `--dark` makes the
walls dark (albedo 0.12). Rendered in full by light tracing:

    python3 tools/corridor.py out/corridor.gltf
    python3 tools/reference.py out/corridor.gltf --out out/corridor.ref.exr --width 128 \
        --height 128 --spp 16384 --integrator ptracer
"""
import sys

from gltf_kit import Gltf, box, sphere


def corridor(path, dark=False):
    g = Gltf()
    w, h, length = 2.0, 2.6, 18.0
    floor, ceiling, back, front, left, right = box([-w / 2, 0, -length], [w / 2, h, 0.0], inward=True)
    wall = 0.12 if dark else 0.6
    g.quads([floor], g.material([0.35, 0.3, 0.25]))
    g.quads([ceiling, front], g.material([wall] * 3))
    g.quads([back], g.material([0.2, 0.35, 0.6]))
    g.quads([left], g.material([wall, wall * 0.55, wall * 0.4]))
    g.quads([right], g.material([wall * 0.8, wall, wall * 0.8]))
    # A grey block halfway, a glass ball near the end.
    g.quads(box([-0.7, 0, -8.6], [-0.1, 0.9, -8.0], inward=False), g.material([0.5, 0.5, 0.5]))
    g.mesh(*sphere([0.3, 0.45, -15.0], 0.45), g.glass(1.5))
    for z, colour, cd in [(-3.0, [1.0, 0.9, 0.8], 6.0), (-9.0, [0.8, 0.9, 1.0], 6.0), (-15.0, [1.0, 0.85, 0.6], 10.0)]:
        g.light({"type": "point", "color": colour, "intensity": cd}, translation=[0.0, 2.3, z])
    g.camera([0.3, 1.5, -0.5], [-0.1, 1.0, -18.0], yfov=0.7)
    g.write(path, "bevy_rppm tools/corridor.py")


if __name__ == "__main__":
    if len(sys.argv) not in (2, 3) or sys.argv[1:2] == ["--dark"]:
        sys.exit("usage: tools/corridor.py OUT.gltf [--dark]")
    corridor(sys.argv[1], dark=sys.argv[2:] == ["--dark"])
