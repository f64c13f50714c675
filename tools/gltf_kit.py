"""What the scene scripts build glTF files with: vector helpers, a glTF writer (`Gltf`) and
boxes, walls, panels and spheres."""
import base64
import json
import math
import struct

def look(direction):
    """The rotation taking −Z to `direction`, +Y kept up."""
    norm = math.sqrt(sum(c * c for c in direction))
    d = [c / norm for c in direction]
    yaw, pitch = math.atan2(-d[0], -d[2]), math.asin(max(-1.0, min(1.0, d[1])))
    cy, sy, cp, sp = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(pitch / 2), math.sin(pitch / 2)
    return [cy * sp, sy * cp, -sy * sp, cy * cp]


def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def unit(a):
    n = math.sqrt(sum(c * c for c in a))
    return [c / n for c in a]


class Gltf:
    """A glTF 2.0 document with its buffer inline; quads and triangles carry flat normals."""

    def __init__(self):
        self.buf = bytearray()
        self.views, self.accessors, self.meshes, self.nodes, self.materials = [], [], [], [], []
        self.lights, self.extensions = [], {"KHR_lights_punctual"}
        self.images = []

    def texture(self, uri):
        """The index of a texture reading the image at `uri` (relative to the .gltf)."""
        if uri not in self.images:
            self.images.append(uri)
        return self.images.index(uri)

    def push(self, fmt, rows, kind, target, minmax=False, component=5126):
        offset = len(self.buf)
        for r in rows:
            self.buf.extend(struct.pack(fmt, *(r if isinstance(r, (list, tuple)) else [r])))
        while len(self.buf) % 4:
            self.buf.append(0)
        self.views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(self.buf) - offset,
                           "target": target})
        acc = {"bufferView": len(self.views) - 1, "componentType": component, "count": len(rows), "type": kind}
        if minmax:
            acc["min"] = [min(r[k] for r in rows) for k in range(3)]
            acc["max"] = [max(r[k] for r in rows) for k in range(3)]
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def material(self, rgb, roughness=1.0, metallic=0.0, **extra):
        m = {"pbrMetallicRoughness": {"baseColorFactor": list(rgb) + [1.0], "metallicFactor": metallic,
                                      "roughnessFactor": roughness}}
        m.update(extra)
        self.extensions.update(extra.get("extensions", {}).keys())
        self.materials.append(m)
        return len(self.materials) - 1

    def glass(self, ior):
        return self.material([1, 1, 1], roughness=0.0, extensions={
            "KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": ior}})

    def tinted_glass(self, ior, colour, distance):
        """Coloured glass: white light keeps `colour` (linear) after `distance` m inside it."""
        return self.material([1, 1, 1], roughness=0.0, extensions={
            "KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": ior},
            "KHR_materials_volume": {"thicknessFactor": 1.0, "attenuationColor": list(colour),
                                     "attenuationDistance": distance}})

    def rough_glass(self, ior, roughness):
        return self.material([1, 1, 1], roughness=roughness, extensions={
            "KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": ior}})

    def emitter(self, rgb, strength):
        return self.material([0, 0, 0], emissiveFactor=list(rgb), extensions={
            "KHR_materials_emissive_strength": {"emissiveStrength": strength}})

    def mesh(self, positions, normals, indices, material, uvs=None):
        prim = {"attributes": {"POSITION": self.push("<3f", positions, "VEC3", 34962, True),
                               "NORMAL": self.push("<3f", normals, "VEC3", 34962)},
                "indices": self.push("<I", indices, "SCALAR", 34963, component=5125), "material": material}
        if uvs:
            prim["attributes"]["TEXCOORD_0"] = self.push("<2f", uvs, "VEC2", 34962)
        self.meshes.append({"primitives": [prim]})
        self.nodes.append({"mesh": len(self.meshes) - 1})

    def quads(self, quads, material, uv_size=None):
        """Quads given counter-clockwise as seen from the side they face; with `uv_size` (m),
        UVs run along the first and last edges, one unit every `uv_size` metres."""
        pos, nor, idx, uvs = [], [], [], []
        for q in quads:
            n = unit(cross(sub(q[1], q[0]), sub(q[2], q[0])))
            b = len(pos)
            pos += q
            nor += [n] * 4
            idx += [b, b + 1, b + 2, b, b + 2, b + 3]
            if uv_size:
                u, v = (math.dist(q[1], q[0]) / uv_size, math.dist(q[3], q[0]) / uv_size)
                uvs += [[0, v], [u, v], [u, 0], [0, 0]]
        self.mesh(pos, nor, idx, material, uvs)

    def light(self, light, translation=None, direction=None):
        self.lights.append(light)
        node = {"extensions": {"KHR_lights_punctual": {"light": len(self.lights) - 1}}}
        if translation:
            node["translation"] = translation
        if direction:
            node["rotation"] = look(direction)
        self.nodes.append(node)

    def camera(self, position, target, yfov=0.9):
        self.cameras = [{"type": "perspective", "perspective": {"yfov": yfov, "znear": 0.05, "zfar": 100.0}}]
        self.nodes.append({"camera": 0, "translation": position, "rotation": look(sub(target, position))})

    def write(self, path, generator, sky=None):
        scene = {"nodes": list(range(len(self.nodes)))}
        if sky:
            # A uniform sky of this linear radiance (bevy_rppm::RppmSky; reference.py's
            # `constant` emitter).
            scene["extras"] = {"rppm_sky": sky}
        doc = {
            "asset": {"version": "2.0", "generator": generator},
            "extensionsUsed": sorted(self.extensions),
            "extensions": {"KHR_lights_punctual": {"lights": self.lights}},
            "scene": 0, "scenes": [scene], "nodes": self.nodes,
            "meshes": self.meshes, "materials": self.materials, "cameras": self.cameras,
            "buffers": [{"byteLength": len(self.buf),
                         "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(self.buf)).decode()}],
            "bufferViews": self.views, "accessors": self.accessors,
        }
        if self.images:
            doc["images"] = [{"uri": uri} for uri in self.images]
            doc["textures"] = [{"source": i} for i in range(len(self.images))]
        with open(path, "w") as f:
            json.dump(doc, f)


def box(lo, hi, inward):
    """The six faces of an axis-aligned box, facing in or out."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    faces = [
        [[x0, y0, z0], [x1, y0, z0], [x1, y0, z1], [x0, y0, z1]],  # bottom, facing −y
        [[x0, y1, z0], [x0, y1, z1], [x1, y1, z1], [x1, y1, z0]],  # top, +y
        [[x0, y0, z0], [x0, y1, z0], [x1, y1, z0], [x1, y0, z0]],  # back, −z
        [[x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]],  # front, +z
        [[x0, y0, z0], [x0, y0, z1], [x0, y1, z1], [x0, y1, z0]],  # left, −x
        [[x1, y0, z0], [x1, y1, z0], [x1, y1, z1], [x1, y0, z1]],  # right, +x
    ]
    return [f[::-1] for f in faces] if inward else faces


def open_box(w=3.0, h=2.4, d=3.0):
    """A new document, the box's height and the six inward faces of a w × h × d box on y = 0
    (the camera looks in through the front, which is left out)."""
    return Gltf(), h, box([-w / 2, 0, -d / 2], [w / 2, h, d / 2], inward=True)


def coloured_walls(g, faces, grey, left, right):
    """Floor, ceiling and back wall in `grey`, the left and right walls in their colours."""
    floor, ceiling, back, _front, left_wall, right_wall = faces
    g.quads([floor, ceiling, back], g.material(grey))
    g.quads([left_wall], g.material(left))
    g.quads([right_wall], g.material(right))


def ceiling_panel(g, y, cx, cz, s, rgb, strength):
    """An emissive square of half-size s facing down at height y, centred at (cx, cz)."""
    g.quads([[[cx - s, y, cz - s], [cx + s, y, cz - s], [cx + s, y, cz + s], [cx - s, y, cz + s]]],
            g.emitter(rgb, strength))


def rotate_y(points, angle, centre):
    c, s = math.cos(angle), math.sin(angle)
    return [[centre[0] + c * (p[0] - centre[0]) + s * (p[2] - centre[2]), p[1],
             centre[2] - s * (p[0] - centre[0]) + c * (p[2] - centre[2])] for p in points]




def sphere(centre, radius, rings=24, segments=48):
    """A UV sphere facing out, with smooth normals."""
    pos, nor, idx = [], [], []
    for i in range(rings + 1):
        theta = math.pi * i / rings
        for j in range(segments + 1):
            phi = 2 * math.pi * j / segments
            n = [math.sin(theta) * math.cos(phi), math.cos(theta), math.sin(theta) * math.sin(phi)]
            nor.append(n)
            pos.append([centre[k] + radius * n[k] for k in range(3)])
    for i in range(rings):
        for j in range(segments):
            a, b = i * (segments + 1) + j, (i + 1) * (segments + 1) + j
            if i > 0:  # not at the poles, where two corners meet
                idx += [a, a + 1, b]
            if i < rings - 1:
                idx += [a + 1, b + 1, b]
    return pos, nor, idx




def inward(mesh):
    """A mesh turned inside out: its faces and normals face the other way."""
    pos, nor, idx = mesh
    flipped = [idx[k + j] for k in range(0, len(idx), 3) for j in (0, 2, 1)]
    return pos, [[-c for c in n] for n in nor], flipped
