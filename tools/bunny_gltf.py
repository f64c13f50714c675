#!/usr/bin/env python3
"""Builds assets/glass_bunny.gltf: a glass Stanford bunny on a diffuse floor, for bevy_rppm.

    python3 tools/bunny_gltf.py PATH_TO_UNPACKED_BUNNY_PACKAGE assets/glass_bunny.gltf

The mesh is the Stanford bunny from the Stanford 3D Scanning Repository
(http://graphics.stanford.edu/data/3Dscanrep/), as packaged by the npm package `bunny`
(1.0.1, Mikola Lysenko, "Public Domain"; 1839 vertices, 3674 triangles, closed and
consistently wound). Get it with `npm pack bunny && tar xzf bunny-*.tgz`, then pass the
unpacked `package` directory (or its index.js). Standard library only.

The scene (y up, metres, the bunny's base centre at the origin):
  * bunny: scaled to 0.9 m tall, centred in x/z on its bounding box, standing on y = 0, smooth
    area-weighted vertex normals; material "glass" (transmission 1, IOR 1.5, volume
    thickness 0.5, roughness 0);
  * floor: diffuse quad x in [-3, 3], z in [-2, 4] at y = 0, colour (0.75, 0.72, 0.68), normal +y;
  * back_wall: diffuse quad x in [-3, 3], y in [0, 4] at z = -2, colour (0.35, 0.45, 0.6),
    normal +z (facing the bunny and the camera);
  * point_light: KHR_lights_punctual point light at (-0.8, 2.2, -0.6), white, 40 cd, no range;
  * camera: perspective (yfov 0.6, aspect 16:9, znear 0.01, zfar 100) at (0, 1.2, 3.2) looking
    at the bunny's mid-height (0, 0.45, 0).
Everything goes into one self-contained .gltf (buffer embedded as a base64 data URI,
u32 indices, counter-clockwise front faces).
"""

import base64
import json
import math
import os
import re
import struct
import sys

BUNNY_HEIGHT = 0.9
LIGHT_POS = (-0.8, 2.2, -0.6)
LIGHT_INTENSITY = 40.0
CAMERA_POS = (0.0, 1.2, 3.2)
FLOOR_X = (-3.0, 3.0)
FLOOR_Z = (-2.0, 4.0)
WALL_Z = -2.0
WALL_HEIGHT = 4.0

GLASS = {
    "name": "glass",
    "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.0},
    "extensions": {
        "KHR_materials_transmission": {"transmissionFactor": 1.0},
        "KHR_materials_ior": {"ior": 1.5},
        "KHR_materials_volume": {"thicknessFactor": 0.5},
    },
}


def diffuse(name, rgb):
    return {
        "name": name,
        "pbrMetallicRoughness": {"baseColorFactor": list(rgb) + [1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0},
        "doubleSided": False,
    }


def load_bunny(path):
    """Reads `exports.positions = [...]` and `exports.cells = [...]` from the package's index.js."""
    if os.path.isdir(path):
        path = os.path.join(path, "index.js")
    with open(path) as f:
        src = f.read()
    data = {}
    for name in ("positions", "cells"):
        m = re.search(r"(?:module\.)?exports\." + name + r"\s*=\s*(\[)", src)
        if not m:
            sys.exit(f"{path}: no exports.{name}")
        value, _ = json.JSONDecoder().raw_decode(src, m.start(1))
        data[name] = value
    return data["positions"], data["cells"]


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def normalize(v):
    n = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    return (v[0] / n, v[1] / n, v[2] / n)


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


def place_bunny(positions):
    """Scales to BUNNY_HEIGHT and moves the bounding box's bottom centre to the origin."""
    lo = [min(p[a] for p in positions) for a in range(3)]
    hi = [max(p[a] for p in positions) for a in range(3)]
    s = BUNNY_HEIGHT / (hi[1] - lo[1])
    cx, cz = 0.5 * (lo[0] + hi[0]), 0.5 * (lo[2] + hi[2])
    return [(f32((p[0] - cx) * s), f32((p[1] - lo[1]) * s), f32((p[2] - cz) * s)) for p in positions]


def vertex_normals(positions, cells):
    """Smooth normals: per vertex, the sum of its faces' unnormalised normals (area-weighted)."""
    acc = [[0.0, 0.0, 0.0] for _ in positions]
    for a, b, c in cells:
        n = cross(sub(positions[b], positions[a]), sub(positions[c], positions[a]))
        for i in (a, b, c):
            acc[i][0] += n[0]
            acc[i][1] += n[1]
            acc[i][2] += n[2]
    out = []
    for v in acc:
        out.append(normalize(v) if any(v) else (0.0, 1.0, 0.0))
    return out


def quat_look_at(eye, target, up=(0.0, 1.0, 0.0)):
    """Rotation (x, y, z, w) that points a glTF camera (looking down local -Z, +Y up) at target."""
    back = normalize(sub(eye, target))  # local +Z
    right = normalize(cross(up, back))  # local +X
    up2 = cross(back, right)  # local +Y
    # Rotation matrix with columns right, up2, back: m[row][col].
    m = [[right[r], up2[r], back[r]] for r in range(3)]
    tr = m[0][0] + m[1][1] + m[2][2]
    if tr > 0.0:
        s = 2.0 * math.sqrt(tr + 1.0)
        q = ((m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s, 0.25 * s)
    elif m[0][0] > m[1][1] and m[0][0] > m[2][2]:
        s = 2.0 * math.sqrt(1.0 + m[0][0] - m[1][1] - m[2][2])
        q = (0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s, (m[2][1] - m[1][2]) / s)
    elif m[1][1] > m[2][2]:
        s = 2.0 * math.sqrt(1.0 + m[1][1] - m[0][0] - m[2][2])
        q = ((m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s, (m[0][2] - m[2][0]) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + m[2][2] - m[0][0] - m[1][1])
        q = ((m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s, (m[1][0] - m[0][1]) / s)
    n = math.sqrt(sum(c * c for c in q))
    return [c / n for c in q]


class Builder:
    def __init__(self):
        self.blob = bytearray()
        self.views = []
        self.accessors = []

    def _view(self, data, target):
        while len(self.blob) % 4:
            self.blob.append(0)
        self.views.append({"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(data), "target": target})
        self.blob += data
        return len(self.views) - 1

    def vec3(self, values, with_bounds):
        data = b"".join(struct.pack("<3f", *v) for v in values)
        acc = {"bufferView": self._view(data, 34962), "componentType": 5126, "count": len(values), "type": "VEC3"}
        if with_bounds:
            vals = [tuple(f32(c) for c in v) for v in values]
            acc["min"] = [min(v[a] for v in vals) for a in range(3)]
            acc["max"] = [max(v[a] for v in vals) for a in range(3)]
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def indices(self, cells):
        flat = [i for t in cells for i in t]
        data = struct.pack(f"<{len(flat)}I", *flat)
        self.accessors.append({"bufferView": self._view(data, 34963), "componentType": 5125, "count": len(flat), "type": "SCALAR"})
        return len(self.accessors) - 1

    def mesh(self, name, positions, normals, cells, material):
        prim = {
            "attributes": {"POSITION": self.vec3(positions, True), "NORMAL": self.vec3(normals, False)},
            "indices": self.indices(cells),
            "material": material,
            "mode": 4,
        }
        return {"name": name, "primitives": [prim]}


def quad(corners, normal):
    """Four corners, counter-clockwise seen from the side `normal` points to; two triangles."""
    n = normalize(cross(sub(corners[1], corners[0]), sub(corners[2], corners[0])))
    assert all(abs(n[i] - normal[i]) < 1e-9 for i in range(3)), (n, normal)
    return corners, [normal] * 4, [(0, 1, 2), (0, 2, 3)]


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    src, out = sys.argv[1], sys.argv[2]
    raw_positions, cells = load_bunny(src)
    n = len(raw_positions)
    if any(not (0 <= i < n) for t in cells for i in t) or any(len(t) != 3 for t in cells):
        sys.exit("bad cells")
    positions = place_bunny(raw_positions)
    normals = vertex_normals(positions, cells)

    x0, x1 = FLOOR_X
    z0, z1 = FLOOR_Z
    floor = quad([(x0, 0.0, z1), (x1, 0.0, z1), (x1, 0.0, z0), (x0, 0.0, z0)], (0.0, 1.0, 0.0))
    wall = quad([(x0, 0.0, WALL_Z), (x1, 0.0, WALL_Z), (x1, WALL_HEIGHT, WALL_Z), (x0, WALL_HEIGHT, WALL_Z)], (0.0, 0.0, 1.0))

    b = Builder()
    meshes = [
        b.mesh("bunny", positions, normals, cells, 0),
        b.mesh("floor", *floor, 1),
        b.mesh("back_wall", *wall, 2),
    ]
    target = (0.0, 0.5 * BUNNY_HEIGHT, 0.0)
    nodes = [
        {"name": "bunny", "mesh": 0},
        {"name": "floor", "mesh": 1},
        {"name": "back_wall", "mesh": 2},
        {"name": "point_light", "translation": list(LIGHT_POS), "extensions": {"KHR_lights_punctual": {"light": 0}}},
        {"name": "camera", "camera": 0, "translation": list(CAMERA_POS), "rotation": quat_look_at(CAMERA_POS, target)},
    ]
    gltf = {
        "asset": {"version": "2.0", "generator": "bevy_rppm tools/bunny_gltf.py"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_ior", "KHR_materials_transmission", "KHR_materials_volume"],
        "extensions": {
            "KHR_lights_punctual": {
                "lights": [{"name": "point_light", "type": "point", "color": [1.0, 1.0, 1.0], "intensity": LIGHT_INTENSITY}]
            }
        },
        "scene": 0,
        "scenes": [{"name": "glass_bunny", "nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": [GLASS, diffuse("floor", (0.75, 0.72, 0.68)), diffuse("back_wall", (0.35, 0.45, 0.6))],
        "cameras": [
            {"name": "camera", "type": "perspective",
             "perspective": {"yfov": 0.6, "aspectRatio": 1.7778, "znear": 0.01, "zfar": 100.0}}
        ],
        "accessors": b.accessors,
        "bufferViews": b.views,
        "buffers": [{
            "byteLength": len(b.blob),
            "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(b.blob)).decode("ascii"),
        }],
    }
    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    with open(out, "w") as f:
        json.dump(gltf, f, indent=1)
        f.write("\n")
    print(f"{out}: {n} vertices, {len(cells)} triangles, {os.path.getsize(out)} bytes")


if __name__ == "__main__":
    main()
