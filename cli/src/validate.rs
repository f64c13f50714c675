//! Checks a glTF or GLB file before Bevy's loader sees it, so that malformed input is one
//! message naming the file and the JSON path instead of a panic, a stack overflow, a hang or
//! an image of nothing. The `gltf` crate (Bevy's own parser) checks the structure and the
//! indices; the byte ranges, index values, node graph, URIs, numbers and cameras are checked
//! here, because Bevy's loader trusts them.

use std::borrow::Cow;
use std::path::{Component, Path, PathBuf};

use base64::Engine;
use serde_json::Value;

use crate::extensions::{SceneExtras, scene_extras};

/// Deeper node hierarchies are refused: Bevy's loader recurses per level, and real assets
/// stay far below this.
pub const MAX_NODE_DEPTH: usize = 128;

/// What the file may reach besides itself.
#[derive(Clone, Copy, Debug, Default)]
pub struct Access {
    /// Buffer and image URIs may name files outside the scene's folder.
    pub outside_files: bool,
}

/// Checks `path`; `Err` is one line naming the file and, where there is one, the JSON path.
pub fn check_gltf(path: &Path, access: Access) -> Result<SceneExtras, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    check_bytes(&bytes, path, access)
        .map_err(|e| format!("{} is not valid glTF: {e}", path.display()))
}

fn check_bytes(bytes: &[u8], path: &Path, access: Access) -> Result<SceneExtras, String> {
    let (json, bin): (Cow<[u8]>, Option<Cow<[u8]>>) = if bytes.starts_with(b"glTF") {
        let glb = gltf::Glb::from_slice(bytes).map_err(|e| format!("GLB: {e}"))?;
        (glb.json, glb.bin)
    } else {
        (Cow::Borrowed(bytes), None)
    };
    let root: Value = serde_json::from_slice(&json).map_err(|e| format!("JSON: {e}"))?;
    finite_numbers(&root, "")?;
    let version = root["asset"]["version"].as_str().unwrap_or("");
    if !version.starts_with("2.") {
        return Err(format!(
            "asset.version is {version:?}; only glTF 2.x is read"
        ));
    }
    // The parser's own validation indexes accessors by these without a check.
    primitive_indices(&root)?;
    if let Err(e) = gltf::Gltf::from_slice(bytes) {
        return Err(match e {
            gltf::Error::Validation(errors) => errors
                .first()
                .map(|(p, e)| format!("{p}: {e}"))
                .unwrap_or_else(|| "invalid".into()),
            e => e.to_string(),
        });
    }
    node_graph(&root)?;
    let folder = path.parent().unwrap_or(Path::new("."));
    let buffers = buffers(&root, bin.as_deref(), folder, access)?;
    accessors(&root, &buffers)?;
    primitives(&root, &buffers)?;
    for (i, image) in list(&root, "images").iter().enumerate() {
        if let Some(uri) = image["uri"].as_str().filter(|u| !u.starts_with("data:")) {
            let at = format!("images[{i}]");
            local_file(&decoded(uri, &at)?, folder, access)
                .map_err(|e| format!("{at}.uri: {e}"))?;
        }
    }
    cameras(&root)?;
    scene_extras(&root)
}

/// A primitive's attributes, indices and morph targets name accessors that exist.
fn primitive_indices(root: &Value) -> Result<(), String> {
    let accessors = list(root, "accessors").len() as u64;
    for (m, mesh) in list(root, "meshes").iter().enumerate() {
        for (p, primitive) in list(mesh, "primitives").iter().enumerate() {
            let at = format!("meshes[{m}].primitives[{p}]");
            let targets = list(primitive, "targets").iter().enumerate();
            let named = primitive["attributes"]
                .as_object()
                .into_iter()
                .flatten()
                .map(|(k, v)| (format!("{at}.attributes.{k}"), v))
                .chain(
                    primitive
                        .get("indices")
                        .map(|v| (format!("{at}.indices"), v)),
                )
                .chain(targets.flat_map(|(t, target)| {
                    let at = at.clone();
                    target
                        .as_object()
                        .into_iter()
                        .flatten()
                        .map(move |(k, v)| (format!("{at}.targets[{t}].{k}"), v))
                }));
            for (path, index) in named {
                if index.as_u64().is_none_or(|i| i >= accessors) {
                    return Err(format!(
                        "{path}: {index} names no accessor (there are {accessors})"
                    ));
                }
            }
        }
    }
    Ok(())
}

fn list<'a>(root: &'a Value, key: &str) -> &'a [Value] {
    root[key].as_array().map(Vec::as_slice).unwrap_or(&[])
}

fn uint(v: &Value) -> u64 {
    v.as_u64().unwrap_or(0)
}

/// Every number fits an f32 (glTF's floats are f32: 1e39 would be infinite).
fn finite_numbers(v: &Value, at: &str) -> Result<(), String> {
    match v {
        Value::Number(n) => match n.as_f64() {
            Some(x) if x.is_finite() && x.abs() <= f32::MAX as f64 => Ok(()),
            _ => Err(format!("{at}: {n} is not a finite 32-bit number")),
        },
        Value::Array(items) => items
            .iter()
            .enumerate()
            .try_for_each(|(i, x)| finite_numbers(x, &format!("{at}[{i}]"))),
        Value::Object(map) => map.iter().try_for_each(|(k, x)| {
            let at = if at.is_empty() {
                k.clone()
            } else {
                format!("{at}.{k}")
            };
            finite_numbers(x, &at)
        }),
        _ => Ok(()),
    }
}

/// Nodes form a forest (one parent at most, no cycle) no deeper than [`MAX_NODE_DEPTH`].
fn node_graph(root: &Value) -> Result<(), String> {
    let nodes = list(root, "nodes");
    let mut parent = vec![None; nodes.len()];
    for (i, node) in nodes.iter().enumerate() {
        for child in node["children"].as_array().into_iter().flatten() {
            let c = uint(child) as usize;
            if c == i {
                return Err(format!("nodes[{i}].children: the node is its own child"));
            }
            if let Some(p) = parent[c].replace(i) {
                return Err(format!(
                    "nodes[{c}] is a child of both nodes[{p}] and nodes[{i}]"
                ));
            }
        }
    }
    for start in 0..nodes.len() {
        let (mut depth, mut at) = (1, start);
        while let Some(p) = parent[at] {
            depth += 1;
            at = p;
            if at == start {
                return Err(format!("nodes[{start}] is its own ancestor"));
            }
            if depth > MAX_NODE_DEPTH {
                return Err(format!(
                    "nodes[{start}] lies more than {MAX_NODE_DEPTH} levels deep"
                ));
            }
        }
    }
    Ok(())
}

/// Each buffer's bytes, at least its `byteLength` of them.
fn buffers(
    root: &Value,
    bin: Option<&[u8]>,
    folder: &Path,
    access: Access,
) -> Result<Vec<Vec<u8>>, String> {
    let mut out = Vec::new();
    for (i, b) in list(root, "buffers").iter().enumerate() {
        let at = format!("buffers[{i}]");
        let data = match b["uri"].as_str() {
            None => bin
                .ok_or(format!(
                    "{at} has no uri and the file has no GLB binary chunk"
                ))?
                .to_vec(),
            Some(uri) => {
                let uri = decoded(uri, &at)?;
                match uri.strip_prefix("data:") {
                    Some(data) => data_uri(data).map_err(|e| format!("{at}.uri: {e}"))?,
                    None => {
                        let file = local_file(&uri, folder, access)
                            .map_err(|e| format!("{at}.uri: {e}"))?;
                        std::fs::read(&file)
                            .map_err(|e| format!("{at}.uri: {}: {e}", file.display()))?
                    }
                }
            }
        };
        let length = uint(&b["byteLength"]);
        if length == 0 {
            return Err(format!("{at}.byteLength is 0"));
        }
        if (data.len() as u64) < length {
            return Err(format!(
                "{at}.byteLength is {length} but the data holds {} bytes",
                data.len()
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// A URI percent-decoded, as Bevy's loader reads it.
fn decoded(uri: &str, at: &str) -> Result<String, String> {
    percent_encoding::percent_decode_str(uri)
        .decode_utf8()
        .map(|u| u.into_owned())
        .map_err(|_| format!("{at}.uri is not UTF-8 once percent-decoded"))
}

fn data_uri(data: &str) -> Result<Vec<u8>, String> {
    let (kind, payload) = data.split_once(',').ok_or("a data URI without a comma")?;
    match kind.strip_suffix(";base64") {
        Some(_) => base64::engine::general_purpose::STANDARD
            .decode(payload)
            .map_err(|e| format!("base64: {e}")),
        None => Ok(payload.as_bytes().to_vec()),
    }
}

/// A relative URI inside the scene's folder (unless `access` allows any), naming a file.
fn local_file(uri: &str, folder: &Path, access: Access) -> Result<PathBuf, String> {
    let relative = Path::new(uri);
    let escapes = relative.is_absolute()
        || uri.contains("://")
        || relative.components().any(|c| c == Component::ParentDir);
    if escapes && !access.outside_files {
        return Err(format!(
            "{uri:?} leaves the scene's folder (rppm render --allow-outside-files allows it)"
        ));
    }
    // Bevy's loader reads an absolute path from its asset root, the scene's folder.
    let inside = relative.strip_prefix("/").unwrap_or(relative);
    let file = folder.join(inside);
    if !file.is_file() {
        let root = if inside == relative {
            ""
        } else {
            " (Bevy reads an absolute path inside the scene's folder)"
        };
        return Err(format!("{} is not a file{root}", file.display()));
    }
    Ok(file)
}

fn components(kind: &str) -> u64 {
    match kind {
        "SCALAR" => 1,
        "VEC2" => 2,
        "VEC3" => 3,
        "VEC4" | "MAT2" => 4,
        "MAT3" => 9,
        _ => 16,
    }
}

fn component_bytes(component_type: u64) -> u64 {
    match component_type {
        5120 | 5121 => 1,
        5122 | 5123 => 2,
        _ => 4,
    }
}

/// A view's bytes, inside its buffer.
fn view_bytes<'a>(root: &Value, buffers: &'a [Vec<u8>], view: usize) -> Result<&'a [u8], String> {
    let v = &root["bufferViews"][view];
    let (offset, length) = (uint(&v["byteOffset"]), uint(&v["byteLength"]));
    let data = &buffers[uint(&v["buffer"]) as usize];
    let end = offset
        .checked_add(length)
        .filter(|&e| e <= data.len() as u64)
        .ok_or(format!(
            "bufferViews[{view}]: bytes {offset}..{} lie past its buffer's {} bytes",
            offset.saturating_add(length),
            data.len()
        ))?;
    Ok(&data[offset as usize..end as usize])
}

/// Every accessor's elements lie inside its view.
fn accessors(root: &Value, buffers: &[Vec<u8>]) -> Result<(), String> {
    for (v, _) in list(root, "bufferViews").iter().enumerate() {
        view_bytes(root, buffers, v)?;
    }
    for (i, a) in list(root, "accessors").iter().enumerate() {
        let count = uint(&a["count"]);
        if count == 0 {
            return Err(format!("accessors[{i}].count is 0"));
        }
        let Some(view) = a["bufferView"].as_u64() else {
            continue; // all zeros, or sparse
        };
        let element = components(a["type"].as_str().unwrap_or(""))
            * component_bytes(uint(&a["componentType"]));
        let stride = root["bufferViews"][view as usize]["byteStride"]
            .as_u64()
            .unwrap_or(element);
        let end = (count - 1)
            .checked_mul(stride)
            .and_then(|s| s.checked_add(element))
            .and_then(|s| s.checked_add(uint(&a["byteOffset"])));
        let have = view_bytes(root, buffers, view as usize)?.len() as u64;
        if end.is_none_or(|e| e > have) {
            return Err(format!(
                "accessors[{i}]: {count} elements of {element} bytes (stride {stride}) do not fit bufferViews[{view}]'s {have} bytes"
            ));
        }
    }
    Ok(())
}

/// A primitive's attributes have one count, and its indices name existing vertices.
fn primitives(root: &Value, buffers: &[Vec<u8>]) -> Result<(), String> {
    let accessors = list(root, "accessors");
    for (m, mesh) in list(root, "meshes").iter().enumerate() {
        for (p, primitive) in list(mesh, "primitives").iter().enumerate() {
            let at = format!("meshes[{m}].primitives[{p}]");
            let mut vertices = None;
            for (name, a) in primitive["attributes"].as_object().into_iter().flatten() {
                let count = uint(&accessors[uint(a) as usize]["count"]);
                match vertices {
                    Some((first, n)) if n != count => {
                        return Err(format!(
                            "{at}.attributes: {name} has {count} elements but {first} has {n}"
                        ));
                    }
                    None => vertices = Some((name.clone(), count)),
                    _ => {}
                }
            }
            let (Some((_, vertices)), Some(index)) = (vertices, primitive["indices"].as_u64())
            else {
                continue;
            };
            let a = &accessors[index as usize];
            let Some(view) = a["bufferView"].as_u64() else {
                continue;
            };
            let size = component_bytes(uint(&a["componentType"])) as usize;
            let start = uint(&a["byteOffset"]) as usize;
            let bytes = &view_bytes(root, buffers, view as usize)?[start..];
            let largest = bytes
                .chunks_exact(size)
                .take(uint(&a["count"]) as usize)
                .map(|c| match size {
                    1 => c[0] as u64,
                    2 => u16::from_le_bytes([c[0], c[1]]) as u64,
                    _ => u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as u64,
                })
                .max()
                .unwrap_or(0);
            if largest >= vertices {
                return Err(format!(
                    "{at}.indices: index {largest} names a vertex past the {vertices} there are"
                ));
            }
        }
    }
    Ok(())
}

/// Cameras that can make an image: a field of view in (0, π), depths in order, and nodes
/// that do not flatten them.
fn cameras(root: &Value) -> Result<(), String> {
    for (i, c) in list(root, "cameras").iter().enumerate() {
        let at = format!("cameras[{i}]");
        let number = |v: &Value| v.as_f64();
        if let Some(p) = c.get("perspective") {
            let yfov = number(&p["yfov"]).unwrap_or(0.0);
            let znear = number(&p["znear"]).unwrap_or(0.0);
            if !(yfov > 1e-4 && yfov < std::f64::consts::PI - 1e-4) {
                return Err(format!(
                    "{at}.perspective.yfov is {yfov}; it must lie in (0, π)"
                ));
            }
            if znear <= 0.0 {
                return Err(format!(
                    "{at}.perspective.znear is {znear}; it must be above 0"
                ));
            }
            if number(&p["zfar"]).is_some_and(|f| f <= znear) {
                return Err(format!("{at}.perspective.zfar is not beyond znear"));
            }
            if number(&p["aspectRatio"]).is_some_and(|a| a <= 0.0) {
                return Err(format!("{at}.perspective.aspectRatio must be above 0"));
            }
        }
        if let Some(o) = c.get("orthographic") {
            let (x, y) = (
                number(&o["xmag"]).unwrap_or(0.0),
                number(&o["ymag"]).unwrap_or(0.0),
            );
            let (near, far) = (
                number(&o["znear"]).unwrap_or(0.0),
                number(&o["zfar"]).unwrap_or(0.0),
            );
            if x == 0.0 || y == 0.0 {
                return Err(format!("{at}.orthographic: xmag and ymag must not be 0"));
            }
            if near < 0.0 || far <= near {
                return Err(format!("{at}.orthographic: zfar must lie beyond znear ≥ 0"));
            }
        }
    }
    for (i, node) in list(root, "nodes").iter().enumerate() {
        if node.get("camera").is_some() && collapsed(node) {
            return Err(format!("nodes[{i}] scales its camera to nothing"));
        }
    }
    Ok(())
}

/// A node transform that maps space onto a plane or a point.
fn collapsed(node: &Value) -> bool {
    let values = |key: &str| -> Vec<f64> {
        node[key]
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(Value::as_f64)
            .collect()
    };
    let scale = values("scale");
    if scale.contains(&0.0) {
        return true;
    }
    let m = values("matrix");
    if m.len() == 16 {
        let det = m[0] * (m[5] * m[10] - m[9] * m[6]) - m[4] * (m[1] * m[10] - m[9] * m[2])
            + m[8] * (m[1] * m[6] - m[5] * m[2]);
        return det == 0.0;
    }
    false
}
