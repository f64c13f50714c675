#!/usr/bin/env python3
"""A probe of nested dielectrics: `lens_caustic`'s room and point light with its glass ball
made a fishbowl, a 4 mm glass shell (ior 1.5, outer and inner spheres) around a ball of water
(ior 1.33) 1 mm inside it, so light crosses glass, air, water, air and glass. `--empty` leaves
the water out. Hanging above what the camera sees, it is rendered in full by light tracing:

    python3 tools/fishbowl.py out/fishbowl.gltf
    python3 tools/reference.py out/fishbowl.gltf --out out/fishbowl.ref.exr --width 128 \
        --height 128 --spp 32768 --integrator ptracer
"""
import sys

from gltf_kit import coloured_walls, open_box, sphere


def inward(pos, nor, idx):
    """The same sphere facing in: normals negated, each triangle's winding reversed."""
    flipped = []
    for k in range(0, len(idx), 3):
        flipped += [idx[k], idx[k + 2], idx[k + 1]]
    return pos, [[-c for c in n] for n in nor], flipped


def fishbowl(path, water=True):
    g, _, faces = open_box()
    coloured_walls(g, faces, [0.7, 0.7, 0.68], [0.65, 0.2, 0.15], [0.2, 0.3, 0.65])
    centre, radius, wall = [0.2, 1.85, -0.6], 0.2, 0.004
    glass = g.glass(1.5)
    g.mesh(*sphere(centre, radius), glass)
    g.mesh(*inward(*sphere(centre, radius - wall)), glass)
    if water:
        g.mesh(*sphere(centre, radius - wall - 0.001), g.glass(1.33))
    g.light({"type": "point", "color": [1.0, 0.95, 0.9], "intensity": 8.0}, translation=[0.2, 2.35, -0.6])
    g.camera([0.0, 1.5, 2.9], [0.0, 0.0, -0.6], yfov=0.8)
    g.write(path, "bevy_rppm tools/fishbowl.py")


if __name__ == "__main__":
    if len(sys.argv) not in (2, 3) or sys.argv[1:2] == ["--empty"]:
        sys.exit("usage: tools/fishbowl.py OUT.gltf [--empty]")
    fishbowl(sys.argv[1], water=sys.argv[2:] != ["--empty"])
