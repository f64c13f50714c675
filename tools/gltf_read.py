"""Reading glTF for tools/reference.py and tools/stage.py: buffers, accessors, the node tree's
world matrices, and PLY meshes for Mitsuba."""
import base64
import json
import os
import struct
import sys
import urllib.parse


COMPONENTS = {5120: ("b", 1), 5121: ("B", 1), 5122: ("h", 2), 5123: ("H", 2), 5125: ("I", 4), 5126: ("f", 4)}
SIZES = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def parse(data, path):
    """A .gltf's or a .glb's bytes: the JSON and a GLB's BIN chunk (None for a .gltf)."""
    if data[:4] != b"glTF":
        return json.loads(data), None
    gltf, binary, at = None, None, 12
    while at + 8 <= len(data):
        size, kind = struct.unpack_from("<II", data, at)
        chunk = data[at + 8:at + 8 + size]
        if kind == 0x4E4F534A:
            gltf = json.loads(chunk)
        elif kind == 0x004E4942:
            binary = chunk
        at += 8 + size
    if gltf is None:
        sys.exit(f"{path}: a GLB without a JSON chunk")
    return gltf, binary


def load(path):
    """A .gltf or a .glb (its buffer without a URI is the BIN chunk): the JSON, its buffers'
    bytes and its folder."""
    folder = os.path.dirname(os.path.abspath(path))
    with open(path, "rb") as f:
        gltf, binary = parse(f.read(), path)
    return gltf, load_buffers(gltf, folder, binary), folder


def uri_bytes(uri, folder):
    """The bytes a glTF URI names: a data URI's, or a file's relative to the folder."""
    if uri.startswith("data:"):
        return base64.b64decode(uri.split(",", 1)[1])
    with open(os.path.join(folder, urllib.parse.unquote(uri)), "rb") as f:
        return f.read()


def load_buffers(gltf, folder, binary=None):
    return [uri_bytes(b["uri"], folder) if "uri" in b else binary for b in gltf.get("buffers", [])]


def image_bytes(gltf, buffers, folder, image):
    """An image's encoded bytes (PNG, JPEG): from its URI or its buffer view (GLB)."""
    if "uri" in image:
        return uri_bytes(image["uri"], folder)
    view = gltf["bufferViews"][image["bufferView"]]
    start = view.get("byteOffset", 0)
    return buffers[view["buffer"]][start:start + view["byteLength"]]


def accessor(gltf, buffers, index):
    a = gltf["accessors"][index]
    view = gltf["bufferViews"][a["bufferView"]]
    fmt, size = COMPONENTS[a["componentType"]]
    width = SIZES[a["type"]]
    stride = view.get("byteStride", size * width)
    start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
    data = buffers[view["buffer"]]
    out = []
    for i in range(a["count"]):
        off = start + i * stride
        out.append(struct.unpack_from("<" + fmt * width, data, off))
    if a.get("normalized") and fmt != "f":
        # Integers standing for [0, 1] (unsigned) or [-1, 1] (signed), as glTF defines them.
        top = {"b": 127.0, "B": 255.0, "h": 32767.0, "H": 65535.0}[fmt]
        out = [tuple(max(c / top, -1.0) for c in v) for v in out]
    return out


def srgb_to_linear(c):
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


def mat_mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def node_matrix(node):
    if "matrix" in node:
        m = node["matrix"]
        return [[m[c * 4 + r] for c in range(4)] for r in range(4)]
    tx, ty, tz = node.get("translation", [0, 0, 0])
    x, y, z, w = node.get("rotation", [0, 0, 0, 1])
    sx, sy, sz = node.get("scale", [1, 1, 1])
    r = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    return [
        [r[0][0] * sx, r[0][1] * sy, r[0][2] * sz, tx],
        [r[1][0] * sx, r[1][1] * sy, r[1][2] * sz, ty],
        [r[2][0] * sx, r[2][1] * sy, r[2][2] * sz, tz],
        [0, 0, 0, 1],
    ]


def walk(gltf):
    """(node, world matrix) for every node of the default scene."""
    identity = [[float(i == j) for j in range(4)] for i in range(4)]
    if not gltf.get("scenes"):
        sys.exit("the glTF file has no scene")
    scene = gltf["scenes"][gltf.get("scene", 0)]
    stack = [(n, identity) for n in scene["nodes"]]
    while stack:
        index, parent = stack.pop()
        node = gltf["nodes"][index]
        world = mat_mul(parent, node_matrix(node))
        yield node, world
        stack.extend((c, world) for c in node.get("children", []))


def transform_point(m, p):
    return [sum(m[r][c] * p[c] for c in range(3)) + m[r][3] for r in range(3)]


def transform_dir(m, d):
    return [sum(m[r][c] * d[c] for c in range(3)) for r in range(3)]


def transform_normal(m, n):
    """A normal under the world matrix m: by its inverse transpose (the cofactors over the
    determinant), unit length."""
    c = [[m[(r + 1) % 3][(k + 1) % 3] * m[(r + 2) % 3][(k + 2) % 3] - m[(r + 1) % 3][(k + 2) % 3] * m[(r + 2) % 3][(k + 1) % 3]
          for k in range(3)] for r in range(3)]
    det = sum(m[0][k] * c[0][k] for k in range(3))
    v = [sum(c[r][k] * n[k] for k in range(3)) * (1.0 if det >= 0 else -1.0) for r in range(3)]
    length = max(sum(x * x for x in v) ** 0.5, 1e-30)
    return [x / length for x in v]


def write_ply(path, positions, faces, uvs=None, colors=None, normals=None):
    """A binary PLY. With `normals` (the glTF's) Mitsuba shades with them; without, it
    computes its own from the faces, which differ where a mesh repeats a vertex (a UV
    sphere's pole: each copy gets the normal of its own triangles)."""
    extra = ("property float nx\nproperty float ny\nproperty float nz\n" if normals else "") + (
        "property float u\nproperty float v\n" if uvs else "") + (
        "property float r\nproperty float g\nproperty float b\n" if colors else "")
    with open(path, "wb") as f:
        f.write(
            (
                "ply\nformat binary_little_endian 1.0\n"
                f"element vertex {len(positions)}\nproperty float x\nproperty float y\nproperty float z\n{extra}"
                f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n"
            ).encode()
        )
        for i, p in enumerate(positions):
            f.write(struct.pack("<3f", *p))
            if normals:
                f.write(struct.pack("<3f", *normals[i]))
            if uvs:
                f.write(struct.pack("<2f", *uvs[i]))
            if colors:
                f.write(struct.pack("<3f", *colors[i][:3]))
        for t in faces:
            f.write(struct.pack("<B3i", 3, *t))
