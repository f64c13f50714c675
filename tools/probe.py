#!/usr/bin/env python3
"""A scale probe: a closed room (one-sided walls, a 15 cd point light) holding a grid of
smooth spheres tessellated so that the scene has about N triangles; the middle sphere is glass,
so caustics and importons are traced too. Geometry goes to a `.bin` beside the `.gltf`.

    python3 tools/probe.py 1000000 out/probe_1m.gltf
    rppm render out/probe_1m.gltf --stats out/probe_1m.json --iterations 4
"""
import json
import math
import os
import sys

import numpy as np


def sphere(centre, radius, segments, rings):
    """A UV sphere: positions, normals and u32 indices."""
    theta = np.linspace(0.0, math.pi, rings + 1)
    phi = np.linspace(0.0, 2.0 * math.pi, segments + 1)[:-1]
    t, p = np.meshgrid(theta[1:-1], phi, indexing="ij")
    n = np.stack([np.sin(t) * np.cos(p), np.cos(t), np.sin(t) * np.sin(p)], -1).reshape(-1, 3)
    n = np.concatenate([[[0, 1, 0]], n, [[0, -1, 0]]]).astype(np.float32)
    pos = (np.asarray(centre, np.float32) + radius * n).astype(np.float32)
    bottom = len(n) - 1
    idx = []
    ring = lambda r, s: 1 + r * segments + (s % segments)  # noqa: E731
    for s in range(segments):
        idx.append([0, ring(0, s + 1), ring(0, s)])
        idx.append([bottom, ring(rings - 2, s), ring(rings - 2, s + 1)])
    for r in range(rings - 2):
        for s in range(segments):
            a, b, c, d = ring(r, s), ring(r, s + 1), ring(r + 1, s), ring(r + 1, s + 1)
            idx.append([a, b, d])
            idx.append([a, d, c])
    return pos, n, np.asarray(idx, np.uint32)


def quad(p0, p1, p2, p3, normal):
    pos = np.asarray([p0, p1, p2, p3], np.float32)
    return pos, np.asarray([normal] * 4, np.float32), np.asarray([[0, 1, 2], [0, 2, 3]], np.uint32)


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: probe.py TRIANGLES OUT.gltf")
    target, out = int(float(sys.argv[1])), sys.argv[2]
    W, H, D = 4.0, 3.0, 4.0
    x0, x1, y0, y1, z0, z1 = -W / 2, W / 2, 0.0, H, -D / 2, D / 2
    materials = []

    def material(rgb, **extra):
        m = {
            "pbrMetallicRoughness": {"baseColorFactor": rgb + [1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}
        }
        m.update(extra)
        materials.append(m)
        return len(materials) - 1

    white, dark = material([0.7, 0.7, 0.7]), material([0.15, 0.12, 0.1])
    red, green = material([0.7, 0.15, 0.1]), material([0.15, 0.6, 0.15])
    blue = material([0.2, 0.3, 0.7])
    glass = material(
        [1.0, 1.0, 1.0],
        extensions={"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.5}},
    )
    materials[glass]["pbrMetallicRoughness"]["roughnessFactor"] = 0.0
    parts = [
        (quad([x0, y0, z0], [x0, y0, z1], [x1, y0, z1], [x1, y0, z0], [0, 1, 0]), dark),
        (quad([x0, y1, z0], [x1, y1, z0], [x1, y1, z1], [x0, y1, z1], [0, -1, 0]), white),
        (quad([x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0], [0, 0, 1]), white),
        (quad([x0, y0, z1], [x0, y1, z1], [x1, y1, z1], [x1, y0, z1], [0, 0, -1]), white),
        (quad([x0, y0, z0], [x0, y1, z0], [x0, y1, z1], [x0, y0, z1], [1, 0, 0]), red),
        (quad([x1, y0, z0], [x1, y0, z1], [x1, y1, z1], [x1, y1, z0], [-1, 0, 0]), green),
    ]
    # A k × k grid of spheres on the floor, each with about target / k² triangles.
    k = 4 if target < 10_000 else 8
    per = max(target - 12, 8) / (k * k)
    segments = max(4, round(math.sqrt(per)))
    rings = max(2, round(per / (2 * segments)) + 1)
    spacing = 2.4 / k
    radius = 0.4 * spacing
    for i in range(k):
        for j in range(k):
            centre = [-1.2 + spacing * (i + 0.5), radius, -1.6 + spacing * (j + 0.5)]
            mid = i == k // 2 and j == k // 2
            parts.append((sphere(centre, radius, segments, rings), glass if mid else [white, blue][(i + j) % 2]))
    buffer = bytearray()
    views, accessors, meshes, nodes = [], [], [], []

    def push(array, target_kind, kind, component, minmax=False):
        offset = len(buffer)
        raw = np.ascontiguousarray(array).tobytes()
        buffer.extend(raw)
        buffer.extend(b"\0" * (-len(buffer) % 4))
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(raw), "target": target_kind})
        count = len(array) if kind != "SCALAR" else array.size
        accessor = {"bufferView": len(views) - 1, "componentType": component, "count": count, "type": kind}
        if minmax:
            accessor["min"], accessor["max"] = array.min(0).tolist(), array.max(0).tolist()
        accessors.append(accessor)
        return len(accessors) - 1

    triangles = 0
    for (pos, nor, idx), mat in parts:
        triangles += len(idx)
        primitive = {
            "attributes": {"POSITION": push(pos, 34962, "VEC3", 5126, True), "NORMAL": push(nor, 34962, "VEC3", 5126)},
            "indices": push(idx.reshape(-1), 34963, "SCALAR", 5125),
            "material": mat,
        }
        meshes.append({"primitives": [primitive]})
        nodes.append({"mesh": len(meshes) - 1})
    nodes.append({"extensions": {"KHR_lights_punctual": {"light": 0}}, "translation": [-0.6, 2.6, 0.3]})
    nodes.append({"camera": 0, "translation": [0.0, 1.6, 1.9], "rotation": [-0.2164, 0.0, 0.0, 0.9763]})
    bin_name = os.path.splitext(os.path.basename(out))[0] + ".bin"
    gltf = {
        "asset": {"version": "2.0", "generator": f"bevy_rppm tools/probe.py ({triangles} triangles)"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_transmission", "KHR_materials_ior"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "color": [1, 1, 1], "intensity": 15.0}]}},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "cameras": [{"type": "perspective", "perspective": {"yfov": 1.0, "znear": 0.05, "zfar": 100.0}}],
        "buffers": [{"uri": bin_name, "byteLength": len(buffer)}],
        "bufferViews": views,
        "accessors": accessors,
    }
    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    with open(os.path.join(os.path.dirname(os.path.abspath(out)), bin_name), "wb") as f:
        f.write(buffer)
    with open(out, "w") as f:
        json.dump(gltf, f)
    print(f"{out}: {triangles} triangles, {len(buffer) / 2**20:.1f} MiB of geometry")


if __name__ == "__main__":
    main()
