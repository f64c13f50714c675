#!/usr/bin/env python3
"""The pool of examples/pool.rs as a glTF with its waves as an animation: a tiled floor and
walls under a sun, and a water surface (clear, ior 1.33) whose height is a sum of travelling
waves, stored as morph targets (sin and cos of each wave) whose weights a glTF animation
turns, one period in `--period` seconds. For `rppm bench motion --script animation` and
`rppm render --animation 0 --animation-time T`.

    python3 tools/pool.py out/pool.gltf
"""
import argparse
import base64
import json
import math
import os
import struct

from gltf_kit import look

CELLS, HALF, DEPTH = 32, 2.0, 1.0
# Travelling waves: amplitude (m), wave vector (rad/m) and cycles per period.
WAVES = [(0.04, (2.1, 0.0), 1), (0.03, (0.0, 2.7), 1), (0.02, (1.7, 1.7), 2)]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out")
    parser.add_argument("--period", type=float, default=4.0, help="seconds per wave cycle")
    parser.add_argument("--keys", type=int, default=48, help="animation keyframes per period")
    args = parser.parse_args()
    buf = bytearray()
    views, accessors, meshes, nodes, materials = [], [], [], [], []

    def push(fmt, rows, kind, target=None, minmax=False, component=5126):
        offset = len(buf)
        for r in rows:
            buf.extend(struct.pack(fmt, *(r if isinstance(r, (list, tuple)) else [r])))
        while len(buf) % 4:
            buf.append(0)
        view = {"buffer": 0, "byteOffset": offset, "byteLength": len(buf) - offset}
        if target:
            view["target"] = target
        views.append(view)
        acc = {"bufferView": len(views) - 1, "componentType": component, "count": len(rows), "type": kind}
        if minmax:
            acc["min"] = [min(r[k] for r in rows) for k in range(3)]
            acc["max"] = [max(r[k] for r in rows) for k in range(3)]
        accessors.append(acc)
        return len(accessors) - 1

    def material(rgb, **extra):
        m = {"pbrMetallicRoughness": {"baseColorFactor": rgb + [1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}
        m.update(extra)
        materials.append(m)
        return len(materials) - 1

    def mesh(positions, normals, indices, mat, targets=None):
        prim = {
            "attributes": {"POSITION": push("<3f", positions, "VEC3", 34962, True),
                           "NORMAL": push("<3f", normals, "VEC3", 34962)},
            "indices": push("<I", indices, "SCALAR", 34963, component=5125),
            "material": mat,
        }
        if targets:
            prim["targets"] = [{"POSITION": push("<3f", p, "VEC3", minmax=True), "NORMAL": push("<3f", n, "VEC3")}
                               for p, n in targets]
        meshes.append({"primitives": [prim]})
        nodes.append({"mesh": len(meshes) - 1})
        return len(nodes) - 1

    light_tile, dark_tile = material([0.9, 0.92, 0.95]), material([0.25, 0.55, 0.85])
    water = material([1.0, 1.0, 1.0], extensions={
        "KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.33}})
    materials[water]["pbrMetallicRoughness"]["roughnessFactor"] = 0.0
    # Floor tiles (8 × 8, two colours) and four inward walls, as in the example.
    for colour in (light_tile, dark_tile):
        pos, nor, idx = [], [], []
        for i in range(8):
            for j in range(8):
                if (i + j) % 2 != (colour == dark_tile):
                    continue
                x0, z0 = -HALF + 0.5 * i, -HALF + 0.5 * j
                b = len(pos)
                pos += [[x0, -DEPTH, z0], [x0, -DEPTH, z0 + 0.5], [x0 + 0.5, -DEPTH, z0 + 0.5], [x0 + 0.5, -DEPTH, z0]]
                nor += [[0, 1, 0]] * 4
                idx += [b, b + 1, b + 2, b, b + 2, b + 3]
        mesh(pos, nor, idx, colour)
    pos, nor, idx = [], [], []
    for k in range(4):
        a = k * math.pi / 2
        c, s = math.cos(a), math.sin(a)
        rot = lambda x, z: [c * x + s * z, -s * x + c * z]  # noqa: E731
        corners = [rot(-HALF, HALF), rot(HALF, HALF)]
        n = rot(0.0, -1.0)
        b = len(pos)
        (x0, z0), (x1, z1) = corners
        pos += [[x0, -DEPTH, z0], [x1, -DEPTH, z1], [x1, 0.1, z1], [x0, 0.1, z0]]
        nor += [[n[0], 0, n[1]]] * 4
        idx += [b, b + 1, b + 2, b, b + 2, b + 3]
    mesh(pos, nor, idx, dark_tile)
    # The water: a flat grid, and per wave a sin and a cos target (height and normal change).
    n = CELLS + 1
    step = 2 * HALF / CELLS
    grid = [[-HALF + step * (k % n), 0.0, -HALF + step * (k // n)] for k in range(n * n)]
    idx = []
    for j in range(CELLS):
        for i in range(CELLS):
            a = j * n + i
            idx += [a, a + n, a + 1, a + 1, a + n, a + n + 1]
    targets = []
    for amp, (kx, kz), _ in WAVES:
        for f, df in ((math.sin, math.cos), (math.cos, lambda t: -math.sin(t))):
            p = [[0.0, amp * f(kx * x + kz * z), 0.0] for x, _, z in grid]
            d = [[-amp * kx * df(kx * x + kz * z), 0.0, -amp * kz * df(kx * x + kz * z)] for x, _, z in grid]
            targets.append((p, d))
    water_node = mesh(grid, [[0, 1, 0]] * len(grid), idx, water, targets)
    # Weights of the wave sin(k·x − ωt) = sin(k·x) cos ωt − cos(k·x) sin ωt.
    times, weights = [], []
    for key in range(args.keys + 1):
        t = args.period * key / args.keys
        times.append(t)
        for _, _, cycles in WAVES:
            w = 2 * math.pi * cycles * t / args.period
            weights += [math.cos(w), -math.sin(w)]
    t_acc = push("<f", times, "SCALAR")
    accessors[t_acc]["min"], accessors[t_acc]["max"] = [0.0], [args.period]
    w_acc = push("<f", weights, "SCALAR")
    meshes[-1]["weights"] = weights[: 2 * len(WAVES)]
    nodes.append({"extensions": {"KHR_lights_punctual": {"light": 0}}, "rotation": look([0.3, -1.0, 0.2])})
    nodes.append({"camera": 0, "translation": [0.0, 3.2, 4.2], "rotation": look([0.0, -4.2, -4.2])})
    gltf = {
        "asset": {"version": "2.0", "generator": "bevy_rppm tools/pool.py"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_transmission", "KHR_materials_ior"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "directional", "color": [1, 1, 1],
                                                           "intensity": 3.0}]}},
        "scene": 0, "scenes": [{"nodes": list(range(len(nodes)))}], "nodes": nodes, "meshes": meshes,
        "materials": materials,
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.05, "zfar": 100.0}}],
        "animations": [{"name": "waves", "channels": [{"sampler": 0, "target": {"node": water_node,
                                                                               "path": "weights"}}],
                        "samplers": [{"input": t_acc, "output": w_acc, "interpolation": "LINEAR"}]}],
        "buffers": [{"byteLength": len(buf),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(buf)).decode()}],
        "bufferViews": views, "accessors": accessors,
    }
    # The README writes to out/…, which a fresh clone lacks.
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(gltf, f)
    print(f"wrote {args.out}: {len(idx) // 3} water triangles, {len(WAVES) * 2} morph targets")


if __name__ == "__main__":
    main()
