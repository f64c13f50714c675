//! The catalogue's base scene, a small valid glTF that every case bends: a floor and a box
//! (indexed, with normals), a point light, a camera, in one buffer.

use base64::Engine;
use serde_json::{Value, json};

/// The base scene's geometry: positions and normals of a floor quad and a box, u16 indices.
pub fn geometry() -> (Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<u16>) {
    let mut positions = vec![
        [-2.0, 0.0, -2.0],
        [2.0, 0.0, -2.0],
        [2.0, 0.0, 2.0],
        [-2.0, 0.0, 2.0],
    ];
    let mut normals = vec![[0.0, 1.0, 0.0]; 4];
    let mut indices: Vec<u16> = vec![0, 2, 1, 0, 3, 2];
    // A box of side 1 on the floor: 6 faces of 4 vertices.
    let faces: [([f32; 3], [f32; 3], [f32; 3]); 6] = [
        ([1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]),
        ([-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]),
        ([0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]),
        ([0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
        ([0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        ([0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
    ];
    for (n, u, v) in faces {
        let base = positions.len() as u16;
        for (a, b) in [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)] {
            let p: [f32; 3] = std::array::from_fn(|k| 0.5 * n[k] + a * u[k] + b * v[k]);
            positions.push([p[0], p[1] + 0.5, p[2]]);
            normals.push(n);
        }
        indices.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
    }
    (positions, normals, indices)
}

/// The buffer: positions, normals, indices (padded to 4 bytes).
pub fn buffer(positions: &[[f32; 3]], normals: &[[f32; 3]], indices: &[u16]) -> Vec<u8> {
    let mut bytes = Vec::new();
    for v in positions.iter().chain(normals) {
        for c in v {
            bytes.extend(c.to_le_bytes());
        }
    }
    for i in indices {
        bytes.extend(i.to_le_bytes());
    }
    while !bytes.len().is_multiple_of(4) {
        bytes.push(0);
    }
    bytes
}

pub fn data_uri(bytes: &[u8]) -> String {
    format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

/// The base scene, its buffer embedded as a data URI.
pub fn base() -> Value {
    let (positions, normals, indices) = geometry();
    let bytes = buffer(&positions, &normals, &indices);
    scene_over(&bytes, positions.len(), indices.len(), data_uri(&bytes))
}

/// The base scene's JSON over `bytes` (laid out as [`buffer`] does) at `uri`.
pub fn scene_over(bytes: &[u8], vertices: usize, indices: usize, uri: String) -> Value {
    let v = vertices as u64;
    json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "point", "color": [1.0, 0.95, 0.9], "intensity": 400.0}
        ]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            {"mesh": 0},
            {"extensions": {"KHR_lights_punctual": {"light": 0}}, "translation": [0.5, 2.5, 0.5]},
            {"camera": 0, "translation": [0.0, 1.5, 4.0], "rotation": [-0.1305262, 0.0, 0.0, 0.9914449]}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.05, "zfar": 100.0}}],
        "meshes": [{"primitives": [{
            "attributes": {"POSITION": 0, "NORMAL": 1},
            "indices": 2,
            "material": 0
        }]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.8}}],
        "buffers": [{"byteLength": bytes.len(), "uri": uri}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 24 * v},
            {"buffer": 0, "byteOffset": 24 * v, "byteLength": 2 * indices}
        ],
        "accessors": [
            {"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": v, "type": "VEC3",
             "min": [-2.0, 0.0, -2.0], "max": [2.0, 1.0, 2.0]},
            {"bufferView": 0, "byteOffset": 12 * v, "componentType": 5126, "count": v, "type": "VEC3"},
            {"bufferView": 1, "byteOffset": 0, "componentType": 5123, "count": indices, "type": "SCALAR"}
        ]
    })
}

/// A GLB of `json` with `bin` as its binary chunk (`bin` None: no chunk).
pub fn glb(json: &Value, bin: Option<&[u8]>) -> Vec<u8> {
    let mut text = serde_json::to_vec(json).expect("JSON serialises");
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let mut chunks = Vec::new();
    chunks.extend((text.len() as u32).to_le_bytes());
    chunks.extend(b"JSON");
    chunks.extend(&text);
    if let Some(bin) = bin {
        let mut bin = bin.to_vec();
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        chunks.extend((bin.len() as u32).to_le_bytes());
        chunks.extend(b"BIN\0");
        chunks.extend(&bin);
    }
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((12 + chunks.len() as u32).to_le_bytes());
    out.extend(chunks);
    out
}
