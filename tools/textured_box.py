#!/usr/bin/env python3
"""Textured scenes the project was not built against (issue 12's textures), closed boxes:

- `box`: the floor a checker texture (albedo 0.8 / 0.1), the back wall in vertex colours, lit
  by a ceiling panel with a striped emissive texture and a point light shining through a
  cut-out screen (an alpha-masked texture with round holes, double-sided) onto the floor;
- `metal`: the floor normal-mapped with round bumps under a grazing point light, the back
  wall gold in stripes of rough metal and Lambertian paint (a metallic-roughness texture),
  a plain emissive ceiling panel;
- `grooves`: normal maps steep enough to face away from the camera, on three surfaces: a
  floor and a red left wall in asymmetric grooves (normals up to 58° off), a back wall of
  bevelled tiles, a warm point light high in the box and the panel, seen from another place;
- `grooves_metal`: the same with its floor gold metal of roughness 0.35 (glossy photons
  scattered off a normal-mapped metal, and reflections in it);
- `samplers`: textures read as their glTF sampler says: a mirrored floor (MIRRORED_REPEAT,
  UVs 0-3), a back wall with a badge clamped to its edge (CLAMP_TO_EDGE, UVs -1-2) and a
  pixel-art panel magnified to the nearest texel (NEAREST).

    python3 tools/textured_box.py assets/suite/textured_box.gltf box
    python3 tools/textured_box.py assets/suite/textured_metal.gltf metal
    python3 tools/textured_box.py assets/suite/grooved_room.gltf grooves
    python3 tools/textured_box.py assets/suite/grooved_metal.gltf grooves_metal
    python3 tools/textured_box.py assets/suite/texture_samplers.gltf samplers
    python3 tools/reference.py assets/suite/textured_box.gltf --out assets/suite/textured_box.ref.exr \\
        --width 256 --height 256 --spp 2048 --variant scalar_rgb
"""
import base64
import json
import math
import os
import struct
import sys
import zlib


def write_png(path, width, height, rgba):
    """8-bit RGBA PNG; `rgba(x, y)` gives 4 ints, row 0 at the top."""
    rows = b"".join(b"\0" + b"".join(struct.pack("4B", *rgba(x, y)) for x in range(width)) for y in range(height))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(rows, 9)))
        f.write(chunk(b"IEND", b""))


def srgb(linear):
    c = linear * 12.92 if linear <= 0.0031308 else 1.055 * linear ** (1 / 2.4) - 0.055
    return round(255 * min(max(c, 0.0), 1.0))


out = sys.argv[1] if len(sys.argv) > 1 else "textured_box.gltf"
variant = sys.argv[2] if len(sys.argv) > 2 else "box"
if variant not in ("box", "metal", "grooves", "grooves_metal", "samplers"):
    sys.exit("textured_box.py: error: the variant is box, metal, grooves, grooves_metal or samplers")
folder = os.path.dirname(os.path.abspath(out))
os.makedirs(os.path.join(folder, "textures"), exist_ok=True)
# 8 × 8 checks on a 64² texture, sRGB-encoded albedos 0.8 and 0.1.
write_png(os.path.join(folder, "textures/checker.png"), 64, 64,
          lambda x, y: [srgb(0.8 if (x // 8 + y // 8) % 2 == 0 else 0.1)] * 3 + [255])
# Stripes along u (8 across, lit / dark 1 : 0.2): an emitter whose power follows its texture.
write_png(os.path.join(folder, "textures/stripes.png"), 32, 8,
          lambda x, y: [srgb(1.0 if (x // 4) % 2 == 0 else 0.2)] * 3 + [255])
# A green leaf screen with a 4 × 4 grid of round holes (alpha 0) in a 64² texture.
write_png(os.path.join(folder, "textures/holes.png"), 64, 64,
          lambda x, y: [srgb(0.2), srgb(0.5), srgb(0.15),
                        0 if math.hypot((x % 16) - 7.5, (y % 16) - 7.5) < 5.5 else 255])



def tangent_normal(nx, ny):
    """A tangent-space normal of x, y components as RGBA8 (z completes the unit vector)."""
    nz = math.sqrt(max(1 - nx * nx - ny * ny, 0.0))
    return [round(255 * (c * 0.5 + 0.5)) for c in (nx, ny, nz)] + [255]


def dome(x, y, cells, size):
    """Tangent-space normal (texture +X right, +Y up) of a round bump per cell, as RGBA8."""
    cell = size / cells
    dx = ((x % cell) + 0.5 - cell / 2) / (0.4 * cell)
    dy = -((y % cell) + 0.5 - cell / 2) / (0.4 * cell)
    r2 = dx * dx + dy * dy
    return tangent_normal(*((0.7 * dx, 0.7 * dy) if r2 < 1 else (0.0, 0.0)))


# Round bumps, 4 × 4 on a 64² normal map.
write_png(os.path.join(folder, "textures/bumps.png"), 64, 64, lambda x, y: dome(x, y, 4, 64))
# Metallic-roughness stripes along u: metal at roughness 0.5 (G 128, B 255) / paint (G 255, B 0).
write_png(os.path.join(folder, "textures/metal_stripes.png"), 32, 8,
          lambda x, y: [0, 128, 255, 255] if (x // 4) % 2 == 0 else [0, 255, 0, 255])



def groove(x, y):
    """Six grooves across u, a cosine and its second harmonic (asymmetric), slope up to 1.6."""
    t = ((x + 0.5) / 128 * 6) % 1.0
    slope = 1.2 * (math.cos(2 * math.pi * t) + 0.35 * math.cos(4 * math.pi * t))
    length = math.sqrt(slope * slope + 1)
    return tangent_normal(-slope / length, 0.0)


def tile(x, y):
    """8 × 8 tiles on 128², bevels 3 texels wide tilted 35° out."""
    cx, cy = x % 16, y % 16
    nx = -0.7 if cx < 3 else (0.7 if cx >= 13 else 0.0)
    ny = 0.7 if cy < 3 else (-0.7 if cy >= 13 else 0.0)
    length = math.sqrt(nx * nx + ny * ny + 1)
    return tangent_normal(nx / length, ny / length)


if variant.startswith("grooves"):
    write_png(os.path.join(folder, "textures/grooves.png"), 128, 16, groove)
    write_png(os.path.join(folder, "textures/tiles.png"), 128, 128, tile)


def ramp(x, y):
    """16², lopsided: red rises along x, blue down y, a dark corner square: mirrored copies
    differ from repeated ones."""
    if x < 5 and y < 5:
        return [srgb(0.05)] * 3 + [255]
    return [srgb(0.1 + 0.8 * x / 15), srgb(0.45), srgb(0.1 + 0.8 * y / 15), 255]


def badge(x, y):
    """16²: a yellow disc on teal, edged in white: clamped, the edge texels stretch."""
    r = math.hypot(x - 7.5, y - 7.5)
    if x in (0, 15) or y in (0, 15):
        return [srgb(0.85)] * 3 + [255]
    return [srgb(0.9), srgb(0.75), srgb(0.1), 255] if r < 5 else [srgb(0.1), srgb(0.5), srgb(0.5), 255]


def pixel_art(x, y):
    """8²: a face of texels meant to be seen magnified as squares (nearest filtering)."""
    eyes = (x, y) in ((2, 2), (5, 2))
    mouth = y == 5 and 1 < x < 6
    dark = eyes or mouth
    return [srgb(0.05 if dark else 0.9), srgb(0.05 if dark else 0.6), srgb(0.05 if dark else 0.15), 255]


if variant == "samplers":
    write_png(os.path.join(folder, "textures/ramp.png"), 16, 16, ramp)
    write_png(os.path.join(folder, "textures/badge.png"), 16, 16, badge)
    write_png(os.path.join(folder, "textures/pixel_art.png"), 8, 8, pixel_art)

buf = b""
views, accessors, meshes, nodes, materials = [], [], [], [], []


def push(values, fmt, target, kind, component, minmax=None):
    global buf
    raw = b"".join(struct.pack(fmt, *v) for v in values)
    offset = len(buf)
    buf += raw
    while len(buf) % 4:
        buf += b"\0"
    views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(raw), "target": target})
    a = {"bufferView": len(views) - 1, "componentType": component, "count": len(values), "type": kind}
    if minmax:
        a["min"], a["max"] = minmax
    accessors.append(a)
    return len(accessors) - 1


def quad(corners, normal, material, uv_scale=1.0, colors=None, uv_lo=0.0):
    """A quad (corners counter-clockwise seen from its front), UVs (0,0) (1,0) (1,1) (0,1) × scale
    + uv_lo."""
    uvs = [(uv_lo + u, uv_lo + v) for u, v in [(0, 0), (uv_scale, 0), (uv_scale, uv_scale), (0, uv_scale)]]
    mn = [min(p[i] for p in corners) for i in range(3)]
    mx = [max(p[i] for p in corners) for i in range(3)]
    attributes = {
        "POSITION": push(corners, "<3f", 34962, "VEC3", 5126, (mn, mx)),
        "NORMAL": push([normal] * 4, "<3f", 34962, "VEC3", 5126),
        "TEXCOORD_0": push(uvs, "<2f", 34962, "VEC2", 5126),
    }
    if colors:
        attributes["COLOR_0"] = push(colors, "<4f", 34962, "VEC4", 5126)
    indices = push([(0,), (1,), (2,), (0,), (2,), (3,)], "<I", 34963, "SCALAR", 5125)
    meshes.append({"primitives": [{"attributes": attributes, "indices": indices, "material": material}]})
    nodes.append({"mesh": len(meshes) - 1})


def material(rgb, texture=None, **extra):
    pbr = {"baseColorFactor": rgb + [1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}
    if texture is not None:
        pbr["baseColorTexture"] = {"index": texture}
    m = {"pbrMetallicRoughness": pbr}
    m.update(extra)
    materials.append(m)
    return len(materials) - 1


x0, x1, y0, y1, z0, z1 = -1.0, 1.0, 0.0, 2.0, -1.0, 1.0
white = material([0.75, 0.75, 0.75])
red = material([0.7, 0.12, 0.1])
green = material([0.12, 0.6, 0.15])
if variant == "box":
    images = [{"uri": "textures/checker.png"}, {"uri": "textures/stripes.png"}, {"uri": "textures/holes.png"}]
    floor = material([1.0, 1.0, 1.0], texture=0, name="checker")
    back = material([1.0, 1.0, 1.0], name="vertex colours")
    back_colors = [[0.9, 0.2, 0.2, 1], [0.2, 0.3, 0.9, 1], [0.9, 0.9, 0.2, 1], [0.9, 0.9, 0.9, 1]]
    panel = material([0.0, 0.0, 0.0], name="striped emitter", emissiveTexture={"index": 1},
                     emissiveFactor=[1.0, 1.0, 1.0], extensions={"KHR_materials_emissive_strength": {"emissiveStrength": 6.0}})
    light = {"translation": [-0.3, 1.5, -0.7], "intensity": 2.0}
elif variant.startswith("grooves"):
    images = [{"uri": "textures/grooves.png"}, {"uri": "textures/tiles.png"}]
    floor = material([0.6, 0.55, 0.5], name="grooved floor", normalTexture={"index": 0})
    if variant == "grooves_metal":
        materials[floor]["pbrMetallicRoughness"].update(baseColorFactor=[0.95, 0.75, 0.45, 1.0], metallicFactor=1.0,
                                                        roughnessFactor=0.35)
    materials[red]["normalTexture"] = {"index": 0}
    back = material([0.8, 0.8, 0.8], name="tiled wall", normalTexture={"index": 1})
    back_colors = None
    panel = material([0.0, 0.0, 0.0], name="emitter", emissiveFactor=[1.0, 1.0, 1.0],
                     extensions={"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}})
    light = {"translation": [0.6, 1.3, -0.4], "intensity": 1.5, "color": [1, 0.9, 0.8]}
elif variant == "samplers":
    images = [{"uri": "textures/ramp.png"}, {"uri": "textures/badge.png"}, {"uri": "textures/pixel_art.png"}]
    floor = material([1.0, 1.0, 1.0], texture=0, name="mirrored ramp")
    back = material([1.0, 1.0, 1.0], texture=1, name="clamped badge")
    art = material([1.0, 1.0, 1.0], texture=2, name="pixel art")
    back_colors = None
    panel = material([0.0, 0.0, 0.0], name="emitter", emissiveFactor=[1.0, 1.0, 1.0],
                     extensions={"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}})
    light = {"translation": [0.5, 1.4, -0.2], "intensity": 1.5}
else:
    images = [{"uri": "textures/bumps.png"}, {"uri": "textures/metal_stripes.png"}]
    floor = material([0.7, 0.7, 0.7], name="bumps", normalTexture={"index": 0})
    back = material([0.9, 0.65, 0.3], name="striped metal")
    materials[back]["pbrMetallicRoughness"].update(metallicFactor=1.0, metallicRoughnessTexture={"index": 1})
    back_colors = None
    panel = material([0.0, 0.0, 0.0], name="emitter", emissiveFactor=[1.0, 1.0, 1.0],
                     extensions={"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}})
    light = {"translation": [-0.9, 0.3, 0.2], "intensity": 1.0}
textures = [{"source": i} for i in range(len(images))]
samplers = []
floor_uv, back_uv = (1.0, 0.0), (1.0, 0.0)
if variant == "samplers":
    # Mirrored (floor, UVs 0..3), clamped to the edge (back wall, UVs -1..2), nearest (left).
    samplers = [{"wrapS": 33648, "wrapT": 33648}, {"wrapS": 33071, "wrapT": 33071},
                {"magFilter": 9728, "minFilter": 9728}]
    for i, t in enumerate(textures):
        t["sampler"] = i
    floor_uv, back_uv = (3.0, 0.0), (3.0, -1.0)
quad([[x0, y0, z1], [x1, y0, z1], [x1, y0, z0], [x0, y0, z0]], [0, 1, 0], floor, *floor_uv[:1],
     uv_lo=floor_uv[1])                                                                                # floor
quad([[x0, y1, z0], [x1, y1, z0], [x1, y1, z1], [x0, y1, z1]], [0, -1, 0], white)                     # ceiling
quad([[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0]], [0, 0, 1], back, back_uv[0], back_colors,
     uv_lo=back_uv[1])                                                                                 # back
quad([[x0, y0, z1], [x0, y0, z0], [x0, y1, z0], [x0, y1, z1]], [1, 0, 0], red)                        # left
quad([[x1, y0, z0], [x1, y0, z1], [x1, y1, z1], [x1, y1, z0]], [-1, 0, 0], green)                     # right
quad([[x0, y0, z1], [x0, y1, z1], [x1, y1, z1], [x1, y0, z1]], [0, 0, -1], white)                     # front (behind camera)
e = 0.35
quad([[-e, y1 - 0.001, z0 + 0.3], [e, y1 - 0.001, z0 + 0.3], [e, y1 - 0.001, z0 + 1.0], [-e, y1 - 0.001, z0 + 1.0]],
     [0, -1, 0], panel)                                                                                # ceiling panel
if variant == "samplers":
    quad([[-0.85, 0.15, -0.6], [-0.25, 0.15, -0.6], [-0.25, 0.75, -0.6], [-0.85, 0.75, -0.6]], [0, 0, 1], art)
if variant == "box":
    screen = material([1.0, 1.0, 1.0], texture=2, name="cut-out screen", alphaMode="MASK", alphaCutoff=0.5,
                      doubleSided=True)
    s, cx, cy, cz = 0.3, -0.3, 0.7, -0.35
    quad([[cx - s, cy, cz - s], [cx - s, cy, cz + s], [cx + s, cy, cz + s], [cx + s, cy, cz - s]],
         [0, 1, 0], screen)                                                                            # cut-out screen
nodes.append({"extensions": {"KHR_lights_punctual": {"light": 0}}, "translation": light["translation"]})
if variant.startswith("grooves"):
    # Turned 0.35 rad to the left and 0.3 rad down.
    yaw, pitch = 0.35, -0.3
    cy, sy, cp, sp = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(pitch / 2), math.sin(pitch / 2)
    nodes.append({"camera": 0, "translation": [0.55, 1.1, 0.95], "rotation": [cy * sp, sy * cp, -sy * sp, cy * cp]})
else:
    nodes.append({"camera": 0, "translation": [0.0, 1.55, 0.95], "rotation": [-0.2231, 0.0, 0.0, 0.9748]})
gltf = {
    "asset": {"version": "2.0", "generator": "tools/textured_box.py"},
    "scene": 0,
    "scenes": [{"nodes": list(range(len(nodes)))}],
    "nodes": nodes,
    "meshes": meshes,
    "materials": materials,
    "images": images,
    "textures": textures,
    **({"samplers": samplers} if samplers else {}),
    "accessors": accessors,
    "bufferViews": views,
    "buffers": [{"byteLength": len(buf), "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
    "cameras": [{"type": "perspective", "perspective": {"yfov": 1.0, "znear": 0.05, "zfar": 100.0, "aspectRatio": 1.0}}],
    "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength"],
    "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "color": light.get("color", [1, 1, 1]), "intensity": light["intensity"]}]}},
}
with open(out, "w") as f:
    json.dump(gltf, f)
