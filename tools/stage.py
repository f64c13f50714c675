#!/usr/bin/env python3
"""Stages a glTF asset for `rppm render`: adds a camera framing it, a sun, a point light and a
white floor under it, and writes the result next to the input (so its files still resolve).

    python3 tools/stage.py FlightHelmet/FlightHelmet.gltf FlightHelmet/staged.gltf [--yaw 30]

A .glb input is split into JSON and a .bin beside the output. The asset's own cameras and
lights are kept but the new camera comes first.
"""
import argparse
import base64
import json
import math
import os
import struct
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gltf_read import parse, transform_point, walk  # noqa: E402


def bounds(gltf):
    lo, hi = [math.inf] * 3, [-math.inf] * 3
    for node, world in walk(gltf):
        for prim in gltf["meshes"][node["mesh"]]["primitives"] if "mesh" in node else []:
            a = gltf["accessors"][prim["attributes"]["POSITION"]]
            for corner in range(8):
                local = [a["max"][k] if corner >> k & 1 else a["min"][k] for k in range(3)]
                p = transform_point(world, local)
                lo = [min(lo[k], p[k]) for k in range(3)]
                hi = [max(hi[k], p[k]) for k in range(3)]
    if lo[0] == math.inf:
        sys.exit("stage.py: error: the scene has no mesh")
    return lo, hi


def read_scene(path, out):
    """The scene's JSON; a GLB's binary chunk is written beside `out` and referenced."""
    with open(path, "rb") as f:
        gltf, binary = parse(f.read(), path)
    if binary is not None:
        name = os.path.splitext(os.path.basename(out))[0] + ".bin"
        with open(os.path.join(os.path.dirname(os.path.abspath(out)), name), "wb") as f:
            f.write(binary)
        gltf["buffers"][0]["uri"] = name
    return gltf


def quaternion_look(direction):
    """Rotation taking −Z to `direction` (unit), with +Y kept up."""
    yaw = math.atan2(-direction[0], -direction[2])
    pitch = math.asin(max(-1.0, min(1.0, direction[1])))
    cy, sy, cp, sp = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(pitch / 2), math.sin(pitch / 2)
    return [cy * sp, sy * cp, -sy * sp, cy * cp]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene")
    parser.add_argument("out")
    parser.add_argument("--yaw", type=float, default=25.0, help="camera azimuth, degrees")
    parser.add_argument("--pitch", type=float, default=15.0, help="camera elevation, degrees")
    parser.add_argument("--sun", type=float, default=3.0, help="sun irradiance, W/m² (lux)")
    args = parser.parse_args()
    # The README writes to out/…, which a fresh clone lacks.
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    gltf = read_scene(args.scene, args.out)
    lo, hi = bounds(gltf)
    centre = [(lo[k] + hi[k]) / 2 for k in range(3)]
    radius = 0.5 * math.dist(lo, hi)
    yaw, pitch = math.radians(args.yaw), math.radians(args.pitch)
    back = [math.sin(yaw) * math.cos(pitch), math.sin(pitch), math.cos(yaw) * math.cos(pitch)]
    fov = 0.7
    distance = 1.15 * radius / math.sin(fov / 2)
    eye = [centre[k] + back[k] * distance for k in range(3)]

    # A floor: a square 8 radii wide just under the asset, facing up.
    s, y = 4 * radius, lo[1]
    corners = [[centre[0] - s, y, centre[2] - s], [centre[0] - s, y, centre[2] + s],
               [centre[0] + s, y, centre[2] + s], [centre[0] + s, y, centre[2] - s]]
    data = b"".join(struct.pack("<3f", *c) for c in corners) + struct.pack("<3f", 0, 1, 0) * 4
    data += struct.pack("<6I", 0, 1, 2, 0, 2, 3)
    buffer = len(gltf.setdefault("buffers", []))
    gltf["buffers"].append({"byteLength": len(data),
                            "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()})
    views = gltf.setdefault("bufferViews", [])
    accessors = gltf.setdefault("accessors", [])
    first = len(accessors)
    for offset, length, count, kind, component in [(0, 48, 4, "VEC3", 5126), (48, 48, 4, "VEC3", 5126),
                                                   (96, 24, 6, "SCALAR", 5125)]:
        views.append({"buffer": buffer, "byteOffset": offset, "byteLength": length})
        accessors.append({"bufferView": len(views) - 1, "componentType": component, "count": count, "type": kind})
    accessors[first]["min"] = [min(c[k] for c in corners) for k in range(3)]
    accessors[first]["max"] = [max(c[k] for c in corners) for k in range(3)]
    gltf.setdefault("materials", []).append({"name": "staged floor", "pbrMetallicRoughness": {
        "baseColorFactor": [0.6, 0.6, 0.6, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}})
    gltf.setdefault("meshes", []).append({"primitives": [{"attributes": {"POSITION": first, "NORMAL": first + 1},
                                                          "indices": first + 2,
                                                          "material": len(gltf["materials"]) - 1}]})
    ext = gltf.setdefault("extensions", {}).setdefault("KHR_lights_punctual", {"lights": []})
    sun, fill = len(ext["lights"]), len(ext["lights"]) + 1
    ext["lights"] += [{"type": "directional", "color": [1.0, 0.95, 0.85], "intensity": args.sun},
                      {"type": "point", "color": [0.8, 0.85, 1.0], "intensity": 4.0 * radius * radius * args.sun}]
    used = gltf.setdefault("extensionsUsed", [])
    if "KHR_lights_punctual" not in used:
        used.append("KHR_lights_punctual")
    nodes = gltf["nodes"]
    camera = len(gltf.setdefault("cameras", []))
    gltf["cameras"].append({"type": "perspective", "perspective": {"yfov": fov, "znear": radius * 0.01,
                                                                   "zfar": radius * 100, "aspectRatio": 1.0}})
    sun_direction = [-0.4, -0.8, -0.45]
    norm = math.sqrt(sum(c * c for c in sun_direction))
    added = [
        {"name": "staged camera", "camera": camera, "translation": eye,
         "rotation": quaternion_look([-b for b in back])},
        {"name": "staged floor", "mesh": len(gltf["meshes"]) - 1},
        {"name": "staged sun", "extensions": {"KHR_lights_punctual": {"light": sun}},
         "rotation": quaternion_look([c / norm for c in sun_direction])},
        {"name": "staged fill", "extensions": {"KHR_lights_punctual": {"light": fill}},
         "translation": [centre[0] - 1.5 * radius, hi[1] + radius, centre[2] + 1.5 * radius]},
    ]
    scene = gltf["scenes"][gltf.get("scene", 0)]
    scene["nodes"] = list(range(len(nodes), len(nodes) + len(added))) + scene["nodes"]
    nodes += added
    with open(args.out, "w") as f:
        json.dump(gltf, f)
    print(f"wrote {args.out}: bounds {lo} .. {hi}, camera at {[round(c, 3) for c in eye]}", file=sys.stderr)


if __name__ == "__main__":
    main()
