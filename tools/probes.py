#!/usr/bin/env python3
"""Probe scenes beyond the suite, each aimed at one way a scene can differ from those the
project was built with (README, "Probes: under water, and between mirrors"):

  underwater    the suite's water_pool seen from under its surface: camera paths start in
                water, the sky is seen through Snell's window, the floor in total internal
                reflection
  mirror_hall   a closed room whose side walls are facing perfect mirrors (an image repeated
                to the eye-depth cap), a rough gold ball (roughness 0.2) and a white block,
                lit by an emissive ceiling panel only

tools/probes.py NAME OUT.gltf, then tools/reference.py OUT.gltf --out REF.exr ... and
rppm render / rppm compare.
"""
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gltf_kit import Gltf, box, ceiling_panel, look, sphere, sub  # noqa: E402
from suite_scenes import water_pool  # noqa: E402


def underwater(path):
    water_pool(path)
    with open(path) as f:
        doc = json.load(f)
    eye, target = [0.3, -0.45, 1.25], [-0.2, -0.25, -1.0]
    camera = next(n for n in doc["nodes"] if "camera" in n)
    camera["translation"], camera["rotation"] = eye, look(sub(target, eye))
    doc["cameras"][0]["perspective"]["yfov"] = 1.0
    with open(path, "w") as f:
        json.dump(doc, f)


def mirror_hall(path):
    g = Gltf()
    w, h, d = 3.0, 2.5, 4.0
    floor, ceiling, back, front, left, right = box([-w / 2, 0, -d / 2], [w / 2, h, d / 2], inward=True)
    g.quads([floor], g.material([0.6, 0.6, 0.58]))
    g.quads([ceiling, back, front], g.material([0.75, 0.75, 0.72]))
    g.quads([left, right], g.material([0.95, 0.95, 0.93], roughness=0.0, metallic=1.0))
    block = box([-0.45, 0, -0.9], [0.05, 0.7, -0.4], inward=False)
    g.quads(block[1:], g.material([0.8, 0.8, 0.8]))  # no bottom face: it stands on the floor
    g.mesh(*sphere([0.5, 0.35, 0.1], 0.35), g.material([1.0, 0.78, 0.34], roughness=0.2, metallic=1.0))
    ceiling_panel(g, h - 0.01, 0.0, -0.3, 0.3, [1.0, 0.95, 0.88], 25.0)
    g.camera([-0.9, 1.4, 1.85], [0.6, 0.6, -1.6], yfov=0.95)
    g.write(path, "bevy_rppm tools/probes.py mirror_hall")


if __name__ == "__main__":
    probes = {"underwater": underwater, "mirror_hall": mirror_hall}
    if len(sys.argv) != 3 or sys.argv[1] not in probes:
        sys.exit(f"usage: {sys.argv[0]} {'|'.join(probes)} OUT.gltf")
    probes[sys.argv[1]](sys.argv[2])
