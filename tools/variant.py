#!/usr/bin/env python3
"""Writes a variant of a glTF scene whose image is known from the scene's own: the same scene
mirrored, scaled, or seen through an orthographic camera. Each probes something a renderer can
get wrong on assets it never saw (a mirroring node, units other than metres, an isometric view,
meshes stored as triangle strips, a wide landscape around a small scene).

    python3 tools/variant.py mirror SCENE.gltf OUT.gltf        # image: the scene's, flipped left to right
    python3 tools/variant.py scale SCENE.gltf OUT.gltf --by 100 # image: the scene's
    python3 tools/variant.py orthographic SCENE.gltf OUT.gltf --width 2.4 --back 1.0
    python3 tools/variant.py strips SCENE.gltf OUT.gltf         # image: the scene's
    python3 tools/variant.py ground SCENE.gltf OUT.gltf --half 500  # a new scene: its own reference
    python3 tools/variant.py transform SCENE.gltf OUT.gltf      # a new scene: its own reference
    python3 tools/variant.py blend SCENE.gltf OUT.gltf          # a new scene: its own reference
    python3 tools/variant.py glb SCENE.gltf OUT.glb             # image: the scene's
    python3 tools/variant.py quantize SCENE.gltf OUT.gltf       # image: the scene's
    python3 tools/variant.py half_metal SCENE.gltf OUT.gltf     # a new scene: its own reference
    python3 tools/variant.py camera SCENE.gltf OUT.gltf --at 0,-0.45,1.35 --look 0,-0.1,-0.8  # the same
    python3 tools/variant.py polish SCENE.gltf OUT.gltf --node floor --roughness 0.15  # the same
    python3 tools/variant.py drop SCENE.gltf OUT.gltf --node 7  # a new scene: its own reference

`transform` gives every base colour texture a KHR_texture_transform (offset 0.1, 0.3, rotation
0.4 rad, scale 2.5, 1.5); `blend` makes every cut-out (alpha MASK) blended (BLEND) at half its
alpha; `glb` packs the scene, its buffers and images into one binary glTF;
`quantize` stores vertex colours and texture coordinates within [0, 1] as normalized 16-bit
integers (as exporters do); `half_metal` makes every glass a smooth half-metal (metallic 0.5, roughness 0,
colour 0.9, 0.7, 0.35); `camera` moves the camera to `--at`, looking at `--look` (water_pool's at
0,-0.45,1.35 looking at 0,-0.1,-0.8 is under the water, seeing its surface from below); `polish`
gives the node named `--node` its own copies of its materials at roughness `--roughness` (a
polished floor: glossy plastic); `drop` takes the root node named (or numbered) `--node` out
of the scene and keeps only the data the rest uses, in one embedded buffer. `ground` adds a grey ground (albedo 0.3) 2·half wide, 5 cm under y = 0, around the scene.
`strips` stores every indexed or plain triangle list as one TRIANGLE_STRIP (its triangles
joined by degenerate ones). Otherwise the meshes go under one new root node (scaled by (-1, 1, 1) or s); lights and the camera stay
at the root, moved to match. `mirror` needs a camera on x = 0 that turns about x only. External
buffer URIs are made absolute so OUT may lie elsewhere; image URIs stay relative (copy or link
the textures beside OUT: Bevy reads an absolute URI inside the scene's folder).
"""
import argparse
import base64
import json
import math
import os
import struct
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gltf_kit import look  # noqa: E402
from gltf_read import uri_bytes  # noqa: E402


def load(path):
    scene = json.load(open(path))
    folder = os.path.dirname(os.path.abspath(path))
    for b in scene.get("buffers", []):
        if "uri" in b and not b["uri"].startswith("data:"):
            b["uri"] = os.path.join(folder, b["uri"])
    return scene


def wrap_meshes(scene, node):
    """Puts the root nodes holding meshes under `node`; returns the other roots."""
    roots = scene["scenes"][scene.get("scene", 0)]["nodes"]
    meshes = [i for i in roots if "mesh" in scene["nodes"][i] or "children" in scene["nodes"][i]]
    rest = [i for i in roots if i not in meshes]
    scene["nodes"].append(dict(node, children=meshes))
    scene["scenes"][scene.get("scene", 0)]["nodes"] = rest + [len(scene["nodes"]) - 1]
    return [scene["nodes"][i] for i in rest]


def mirror(scene, _args):
    for node in wrap_meshes(scene, {"name": "mirrored", "scale": [-1, 1, 1]}):
        if "camera" in node:
            t, q = node.get("translation", [0, 0, 0]), node.get("rotation", [0, 0, 0, 1])
            if abs(t[0]) > 1e-9 or abs(q[1]) > 1e-9 or abs(q[2]) > 1e-9:
                raise SystemExit("variant.py: mirror needs a camera on x = 0 turning about x only")
        elif "translation" in node:
            node["translation"][0] *= -1
            if "rotation" in node:
                x, y, z, w = node["rotation"]
                node["rotation"] = [x, -y, -z, w]


def scale(scene, args):
    s = args.by
    for node in wrap_meshes(scene, {"name": "scaled", "scale": [s, s, s]}):
        if "translation" in node:
            node["translation"] = [t * s for t in node["translation"]]
    # Radiance is kept: a punctual light's intensity grows with the distances squared.
    for light in scene.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", []):
        if light["type"] in ("point", "spot"):
            light["intensity"] = light.get("intensity", 1.0) * s * s
        if "range" in light:
            light["range"] *= s
        extras = light.get("extras", {})
        if "rppm_radius" in extras:
            extras["rppm_radius"] *= s
    for camera in scene.get("cameras", []):
        for kind in ("perspective", "orthographic"):
            if kind in camera:
                camera[kind]["znear"] *= s
                if "zfar" in camera[kind]:
                    camera[kind]["zfar"] *= s
                if kind == "orthographic":
                    camera[kind]["xmag"] *= s
                    camera[kind]["ymag"] *= s
    for material in scene.get("materials", []):
        volume = material.get("extensions", {}).get("KHR_materials_volume")
        if volume:
            for key in ("attenuationDistance", "thicknessFactor"):
                if key in volume:
                    volume[key] *= s


def orthographic(scene, args):
    # Bevy's glTF loader makes the view xmag wide (not 2·xmag as the glTF spec reads it).
    scene["cameras"] = [{"type": "orthographic", "orthographic": {
        "xmag": args.width, "ymag": args.width, "znear": 0.05, "zfar": 100.0}}]
    for node in scene["nodes"]:
        if "camera" in node:
            node["camera"] = 0
            x, y, z, w = node.get("rotation", [0, 0, 0, 1])
            forward = [-2 * (x * z + w * y), -2 * (y * z - w * x), -(1 - 2 * (x * x + y * y))]
            t = node.get("translation", [0, 0, 0])
            node["translation"] = [t[i] - args.back * forward[i] for i in range(3)]


def accessor_values(scene, index):
    """The integers of a scalar accessor (indices), read from its buffer."""
    accessor = scene["accessors"][index]
    view = scene["bufferViews"][accessor["bufferView"]]
    uri = scene["buffers"][view["buffer"]]["uri"]
    data = base64.b64decode(uri.split(",", 1)[1]) if uri.startswith("data:") else open(uri, "rb").read()
    kind = {5121: "B", 5123: "H", 5125: "I"}[accessor["componentType"]]
    start = view.get("byteOffset", 0) + accessor.get("byteOffset", 0)
    stride = view.get("byteStride", struct.calcsize(kind))
    return [struct.unpack_from("<" + kind, data, start + i * stride)[0] for i in range(accessor["count"])]


def strips(scene, _args):
    for mesh in scene["meshes"]:
        for primitive in mesh["primitives"]:
            if primitive.get("mode", 4) != 4:
                continue
            if "indices" in primitive:
                corners = accessor_values(scene, primitive["indices"])
            else:
                corners = list(range(scene["accessors"][primitive["attributes"]["POSITION"]]["count"]))
            strip = []
            for t in range(0, len(corners) - 2, 3):
                a, b, c = corners[t:t + 3]
                if strip:
                    # Degenerate joins (a corner repeated around each): each triangle starts
                    # at an even place, keeping its front.
                    strip += [strip[-1], a]
                    if len(strip) % 2 == 1:
                        strip.append(a)
                strip += [a, b, c]
            data = struct.pack(f"<{len(strip)}I", *strip)
            scene["buffers"].append({"byteLength": len(data),
                                     "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()})
            scene["bufferViews"].append({"buffer": len(scene["buffers"]) - 1, "byteLength": len(data)})
            scene["accessors"].append({"bufferView": len(scene["bufferViews"]) - 1, "componentType": 5125,
                                       "count": len(strip), "type": "SCALAR"})
            primitive["indices"] = len(scene["accessors"]) - 1
            primitive["mode"] = 5


def ground(scene, args):
    half, y = args.half, -0.05
    corners = [(-half, y, -half), (-half, y, half), (half, y, half), (half, y, -half)]
    data = b"".join(struct.pack("<3f", *c) for c in corners) + struct.pack("<12f", *[0, 1, 0] * 4)
    data += struct.pack("<6H", 0, 1, 2, 0, 2, 3) + b"\0\0"
    scene["buffers"].append({"byteLength": len(data),
                             "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()})
    buffer = len(scene["buffers"]) - 1
    views = len(scene["bufferViews"])
    scene["bufferViews"] += [{"buffer": buffer, "byteOffset": 0, "byteLength": 48},
                             {"buffer": buffer, "byteOffset": 48, "byteLength": 48},
                             {"buffer": buffer, "byteOffset": 96, "byteLength": 12}]
    accessors = len(scene["accessors"])
    scene["accessors"] += [
        {"bufferView": views, "componentType": 5126, "count": 4, "type": "VEC3",
         "min": [-half, y, -half], "max": [half, y, half]},
        {"bufferView": views + 1, "componentType": 5126, "count": 4, "type": "VEC3"},
        {"bufferView": views + 2, "componentType": 5123, "count": 6, "type": "SCALAR"}]
    scene["materials"].append({"name": "ground", "pbrMetallicRoughness": {
        "baseColorFactor": [0.3, 0.3, 0.3, 1], "metallicFactor": 0, "roughnessFactor": 1}})
    scene["meshes"].append({"primitives": [{
        "attributes": {"POSITION": accessors, "NORMAL": accessors + 1}, "indices": accessors + 2,
        "material": len(scene["materials"]) - 1}]})
    scene["nodes"].append({"name": "ground", "mesh": len(scene["meshes"]) - 1})
    scene["scenes"][scene.get("scene", 0)]["nodes"].append(len(scene["nodes"]) - 1)


def transform(scene, _args):
    for m in scene.get("materials", []):
        texture = m.get("pbrMetallicRoughness", {}).get("baseColorTexture")
        if texture is not None:
            texture.setdefault("extensions", {})["KHR_texture_transform"] = {
                "offset": [0.1, 0.3], "rotation": 0.4, "scale": [2.5, 1.5]}
    scene.setdefault("extensionsUsed", []).append("KHR_texture_transform")


def blend(scene, _args):
    for m in scene.get("materials", []):
        if m.get("alphaMode") == "MASK":
            m["alphaMode"] = "BLEND"
            m.pop("alphaCutoff", None)
            pbr = m.setdefault("pbrMetallicRoughness", {})
            pbr["baseColorFactor"] = pbr.get("baseColorFactor", [1, 1, 1, 1])[:3] + [
                0.5 * pbr.get("baseColorFactor", [1, 1, 1, 1])[3]]


def quantize(scene, args):
    from gltf_read import accessor, load_buffers

    buffers = load_buffers(scene, os.path.dirname(os.path.abspath(args.scene)))
    blob = b""
    for mesh in scene.get("meshes", []):
        for prim in mesh["primitives"]:
            for name in ("COLOR_0", "TEXCOORD_0"):
                index = prim["attributes"].get(name)
                if index is None or scene["accessors"][index]["componentType"] != 5126:
                    continue
                values = accessor(scene, buffers, index)
                if any(not 0.0 <= c <= 1.0 for v in values for c in v):
                    continue
                kind = scene["accessors"][index]["type"]
                raw = b"".join(struct.pack(f"<{len(v)}H", *(round(c * 65535) for c in v)) for v in values)
                scene["bufferViews"].append({"buffer": len(scene["buffers"]), "byteOffset": len(blob),
                                             "byteLength": len(raw)})
                scene["accessors"].append({"bufferView": len(scene["bufferViews"]) - 1, "componentType": 5123,
                                           "normalized": True, "count": len(values), "type": kind})
                prim["attributes"][name] = len(scene["accessors"]) - 1
                blob += raw + b"\0" * (-len(raw) % 4)
    scene["buffers"].append({"byteLength": len(blob),
                             "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()})


def half_metal(scene, _args):
    for m in scene.get("materials", []):
        if "KHR_materials_transmission" in m.get("extensions", {}):
            m["extensions"] = {}
            m["pbrMetallicRoughness"] = {"baseColorFactor": [0.9, 0.7, 0.35, 1], "metallicFactor": 0.5,
                                         "roughnessFactor": 0.0}


def camera(scene, args):
    at, target = ([float(v) for v in text.split(",")] for text in (args.at, args.look))
    if len(at) != 3 or len(target) != 3 or at == target:
        raise SystemExit("variant.py: --at and --look are two different points x,y,z")
    for node in scene["nodes"]:
        if "camera" in node:
            node.pop("matrix", None)
            node["translation"], node["rotation"] = at, look([t - a for t, a in zip(target, at)])


def polish(scene, args):
    nodes = [n for n in scene["nodes"] if n.get("name") == args.node and "mesh" in n]
    if not nodes:
        raise SystemExit(f"variant.py: no node named {args.node!r} holds a mesh")
    for node in nodes:
        for prim in scene["meshes"][node["mesh"]]["primitives"]:
            material = json.loads(json.dumps(scene["materials"][prim.get("material", 0)]))
            material["name"] = f"{material.get('name', 'material')}_polished"
            material.setdefault("pbrMetallicRoughness", {})["roughnessFactor"] = args.roughness
            scene["materials"].append(material)
            prim["material"] = len(scene["materials"]) - 1


def drop(scene, args):
    roots = scene["scenes"][scene.get("scene", 0)]["nodes"]
    named = [i for i in roots if scene["nodes"][i].get("name") == args.node or str(i) == args.node]
    if not named:
        raise SystemExit(f"variant.py: no root node {args.node}")
    if any("bufferView" in image for image in scene.get("images", [])):
        raise SystemExit("variant.py: drop keeps images as files only")
    if "animations" in scene or "skins" in scene:
        raise SystemExit("variant.py: drop needs a scene without animations or skins")
    roots.remove(named[0])
    stack = [named[0]]
    while stack:
        node = scene["nodes"][stack.pop()]
        stack += node.pop("children", [])
        node.pop("mesh", None)
    # The meshes nodes still hold, and the accessors they use, copied into a new buffer.
    kept = sorted({n["mesh"] for n in scene["nodes"] if "mesh" in n})
    for node in scene["nodes"]:
        if "mesh" in node:
            node["mesh"] = kept.index(node["mesh"])
    scene["meshes"] = [scene["meshes"][m] for m in kept]
    used = set()
    for mesh in scene["meshes"]:
        for primitive in mesh["primitives"]:
            used |= set(primitive["attributes"].values()) | {primitive.get("indices")}
            for target in primitive.get("targets", []):
                used |= set(target.values())
    folder = os.path.dirname(os.path.abspath(args.scene))
    buffers = [uri_bytes(b["uri"], folder) for b in scene["buffers"]]
    blob, views, moved = bytearray(), [], {}
    for index in sorted(used - {None}):
        accessor = scene["accessors"][index]
        view = dict(scene["bufferViews"][accessor["bufferView"]])
        start = view.get("byteOffset", 0)
        data = buffers[view["buffer"]][start:start + view["byteLength"]]
        blob += b"\0" * (-len(blob) % 4)
        views.append(dict(view, buffer=0, byteOffset=len(blob)))
        blob += data
        moved[index] = len(moved)
        accessor["bufferView"] = len(views) - 1
    scene["accessors"] = [scene["accessors"][i] for i in sorted(moved)]
    scene["bufferViews"] = views
    for mesh in scene["meshes"]:
        for primitive in mesh["primitives"]:
            primitive["attributes"] = {k: moved[v] for k, v in primitive["attributes"].items()}
            if "indices" in primitive:
                primitive["indices"] = moved[primitive["indices"]]
            for target in primitive.get("targets", []):
                target.update({k: moved[v] for k, v in target.items()})
    scene["buffers"] = [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64,"
                         + base64.b64encode(bytes(blob)).decode()}]


def glb(scene, args):
    """Every buffer and image into one BIN chunk (4-byte aligned), written as OUT (GLB)."""
    folder = os.path.dirname(os.path.abspath(args.scene))
    blob, starts = b"", []
    for b in scene.get("buffers", []):
        starts.append(len(blob))
        blob += uri_bytes(b["uri"], folder)
        blob += b"\0" * (-len(blob) % 4)
    for view in scene.get("bufferViews", []):
        view["byteOffset"] = view.get("byteOffset", 0) + starts[view["buffer"]]
        view["buffer"] = 0
    for image in scene.get("images", []):
        if "uri" in image:
            data = uri_bytes(image.pop("uri"), folder)
            scene["bufferViews"].append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)})
            image["bufferView"] = len(scene["bufferViews"]) - 1
            image.setdefault("mimeType", "image/jpeg" if data[:2] == b"\xff\xd8" else "image/png")
            blob += data + b"\0" * (-len(data) % 4)
    scene["buffers"] = [{"byteLength": len(blob)}]
    text = json.dumps(scene).encode()
    text += b" " * (-len(text) % 4)
    with open(args.out, "wb") as f:
        f.write(struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(text) + 8 + len(blob)))
        f.write(struct.pack("<II", len(text), 0x4E4F534A) + text)
        f.write(struct.pack("<II", len(blob), 0x004E4942) + blob)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("kind", choices=["mirror", "scale", "orthographic", "strips", "ground", "transform", "blend", "glb", "quantize", "half_metal", "camera", "polish", "drop"])
    parser.add_argument("scene")
    parser.add_argument("out")
    parser.add_argument("--by", type=float, default=100.0, help="scale: the factor")
    parser.add_argument("--width", type=float, default=2.0, help="orthographic: the view's width, m")
    parser.add_argument("--back", type=float, default=0.0, help="orthographic: move the camera back, m")
    parser.add_argument("--half", type=float, default=500.0, help="ground: half its width, m")
    parser.add_argument("--at", default="0,-0.45,1.35", help="camera: where it stands, x,y,z in m")
    parser.add_argument("--look", default="0,-0.1,-0.8", help="camera: the point it looks at, x,y,z in m")
    parser.add_argument("--node", default="floor", help="polish: the node whose materials it polishes; drop: the node it takes out")
    parser.add_argument("--roughness", type=float, default=0.15, help="polish: the roughness they get")
    args = parser.parse_args()
    if not math.isfinite(args.by) or args.by <= 0:
        raise SystemExit("variant.py: --by must be a positive number")
    scene = load(args.scene)
    {"mirror": mirror, "scale": scale, "orthographic": orthographic, "strips": strips, "ground": ground,
     "transform": transform, "blend": blend, "glb": glb,
     "quantize": quantize, "half_metal": half_metal, "camera": camera, "polish": polish, "drop": drop}[args.kind](scene, args)
    if args.kind != "glb":
        json.dump(scene, open(args.out, "w"))
    print(f"wrote {args.out}: {args.kind} of {args.scene}")


if __name__ == "__main__":
    main()
