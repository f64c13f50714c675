//! glTF and GLB structure.

use serde_json::json;

use super::{Edit, edited, error, json_bytes, render, set};
use crate::catalogue::scene::{buffer, geometry, glb, scene_over};
use crate::catalogue::{Case, Expect};

/// glTF structure: the file, its buffers, views, accessors, indices and nodes.
pub fn structure() -> Vec<Case> {
    let g = "structure";
    let bad = "is not valid glTF";
    let raw = |name: &str, bytes: Vec<u8>, expect| {
        Case::new(
            name,
            g,
            vec![("scene.gltf".into(), bytes)],
            render("scene.gltf"),
            expect,
        )
    };
    let mut cases = vec![
        raw("an empty file", vec![], error(bad)),
        raw("not JSON", b"{ this is not gltf".to_vec(), error(bad)),
        raw("a JSON array", b"[1, 2, 3]".to_vec(), error(bad)),
        raw("JSON null", b"null".to_vec(), error(bad)),
        raw(
            "binary noise",
            (0..4096u32)
                .map(|i| (i.wrapping_mul(2654435761) >> 24) as u8)
                .collect(),
            error(bad),
        ),
        raw("no asset", json_bytes(&json!({"scenes": [{}]})), error(bad)),
        raw("an empty object", b"{}".to_vec(), error(bad)),
    ];
    // The base scene's material textured by one image at `uri`.
    let textured = |uri: &str| {
        let uri = uri.to_string();
        move |s: &mut serde_json::Value| {
            set(s, "/images", json!([{ "uri": uri }]));
            set(s, "/textures", json!([{"source": 0}]));
            set(
                s,
                "/materials/0/pbrMetallicRoughness/baseColorTexture",
                json!({"index": 0}),
            );
        }
    };
    let edits: Vec<(&str, Edit)> = vec![
        (
            "asset.version 1.0",
            Box::new(|s| set(s, "/asset/version", json!("1.0"))),
        ),
        (
            "asset.version 3.0",
            Box::new(|s| set(s, "/asset/version", json!("3.0"))),
        ),
        (
            "asset.version a number",
            Box::new(|s| set(s, "/asset/version", json!(2))),
        ),
        (
            "byteLength beyond the data",
            Box::new(|s| set(s, "/buffers/0/byteLength", json!(100_000))),
        ),
        (
            "byteLength 0",
            Box::new(|s| set(s, "/buffers/0/byteLength", json!(0))),
        ),
        (
            "a data URI cut short",
            Box::new(|s| {
                let uri = s["buffers"][0]["uri"].as_str().unwrap().to_string();
                set(s, "/buffers/0/uri", json!(uri[..uri.len() / 2].to_string()));
            }),
        ),
        (
            "a data URI that is not base64",
            Box::new(|s| {
                set(
                    s,
                    "/buffers/0/uri",
                    json!("data:application/octet-stream;base64,@@@@"),
                )
            }),
        ),
        (
            "a data URI without a comma",
            Box::new(|s| set(s, "/buffers/0/uri", json!("data:application/octet-stream"))),
        ),
        (
            "a buffer file that is missing",
            Box::new(|s| set(s, "/buffers/0/uri", json!("missing.bin"))),
        ),
        (
            "a buffer URI up and out",
            Box::new(|s| set(s, "/buffers/0/uri", json!("../../../../etc/passwd"))),
        ),
        (
            "an absolute buffer URI",
            Box::new(|s| set(s, "/buffers/0/uri", json!("/etc/passwd"))),
        ),
        (
            "a buffer URI over HTTP",
            Box::new(|s| set(s, "/buffers/0/uri", json!("http://example.com/x.bin"))),
        ),
        (
            "a percent-encoded URI that is not UTF-8",
            Box::new(|s| set(s, "/buffers/0/uri", json!("%ff%fe.bin"))),
        ),
        (
            "a buffer view past its buffer",
            Box::new(|s| set(s, "/bufferViews/1/byteLength", json!(100_000))),
        ),
        (
            "a buffer view offset of 1e15",
            Box::new(|s| {
                set(
                    s,
                    "/bufferViews/0/byteOffset",
                    json!(1_000_000_000_000_000u64),
                )
            }),
        ),
        (
            "a buffer view of a missing buffer",
            Box::new(|s| set(s, "/bufferViews/0/buffer", json!(7))),
        ),
        (
            "a byteStride of 2",
            Box::new(|s| set(s, "/bufferViews/0/byteStride", json!(2))),
        ),
        (
            "an accessor count past its view",
            Box::new(|s| set(s, "/accessors/0/count", json!(1_000_000))),
        ),
        (
            "an accessor count of 0",
            Box::new(|s| set(s, "/accessors/0/count", json!(0))),
        ),
        (
            "an accessor offset past its view",
            Box::new(|s| set(s, "/accessors/1/byteOffset", json!(4096))),
        ),
        (
            "an accessor of a missing view",
            Box::new(|s| set(s, "/accessors/0/bufferView", json!(9))),
        ),
        (
            "an accessor of an unknown type",
            Box::new(|s| set(s, "/accessors/0/type", json!("VEC7"))),
        ),
        (
            "an accessor of an unknown component type",
            Box::new(|s| set(s, "/accessors/0/componentType", json!(1234))),
        ),
        (
            "a POSITION accessor out of range",
            Box::new(|s| set(s, "/meshes/0/primitives/0/attributes/POSITION", json!(99))),
        ),
        (
            "an indices accessor out of range",
            Box::new(|s| set(s, "/meshes/0/primitives/0/indices", json!(99))),
        ),
        (
            "an index past the vertices",
            Box::new(|s| {
                set(s, "/meshes/0/primitives/0/attributes/NORMAL", json!(1));
                set(s, "/accessors/0/count", json!(3));
                set(s, "/accessors/1/count", json!(3));
            }),
        ),
        (
            "attributes of different counts",
            Box::new(|s| set(s, "/accessors/1/count", json!(3))),
        ),
        (
            "no POSITION attribute",
            Box::new(|s| set(s, "/meshes/0/primitives/0/attributes", json!({"NORMAL": 1}))),
        ),
        (
            "an unknown alpha mode",
            Box::new(|s| set(s, "/materials/0/alphaMode", json!("SOMETIMES"))),
        ),
        (
            "an unknown required extension",
            Box::new(|s| set(s, "/extensionsRequired", json!(["EXT_from_the_future"]))),
        ),
        (
            "a morph target of a missing accessor",
            Box::new(|s| {
                set(
                    s,
                    "/meshes/0/primitives/0/targets",
                    json!([{"POSITION": 50}]),
                )
            }),
        ),
        (
            "a node's mesh out of range",
            Box::new(|s| set(s, "/nodes/0/mesh", json!(5))),
        ),
        (
            "a material out of range",
            Box::new(|s| set(s, "/meshes/0/primitives/0/material", json!(5))),
        ),
        (
            "a node's camera out of range",
            Box::new(|s| set(s, "/nodes/2/camera", json!(5))),
        ),
        (
            "a scene's node out of range",
            Box::new(|s| set(s, "/scenes/0/nodes", json!([0, 1, 2, 40]))),
        ),
        (
            "the default scene out of range",
            Box::new(|s| set(s, "/scene", json!(3))),
        ),
        (
            "a child out of range",
            Box::new(|s| set(s, "/nodes/0/children", json!([17]))),
        ),
        (
            "a node its own child",
            Box::new(|s| set(s, "/nodes/0/children", json!([0]))),
        ),
        (
            "a cycle of two nodes",
            Box::new(|s| {
                set(s, "/nodes/0/children", json!([1]));
                set(s, "/nodes/1/children", json!([0]));
            }),
        ),
        (
            "a node with two parents",
            Box::new(|s| {
                set(s, "/nodes/0/children", json!([1]));
                set(s, "/nodes/2/children", json!([1]));
            }),
        ),
        (
            "a texture of a missing image",
            Box::new(|s| {
                set(s, "/textures", json!([{"source": 4}]));
                set(
                    s,
                    "/materials/0/pbrMetallicRoughness/baseColorTexture",
                    json!({"index": 0}),
                );
            }),
        ),
        (
            "an image file that is missing",
            Box::new(textured("missing.png")),
        ),
        (
            "an image URI up and out",
            Box::new(textured("../../../../etc/hostname")),
        ),
    ];
    cases.extend(
        edits
            .into_iter()
            .map(|(name, edit)| edited(name, g, error(bad), edit)),
    );
    // Found by the loader, not the checks: the render would go on without the texture.
    let mut noise = edited(
        "an image file that is not an image",
        g,
        error("Invalid PNG signature"),
        textured("noise.png"),
    );
    noise
        .files
        .push(("noise.png".into(), b"not a PNG".repeat(40)));
    cases.push(noise);
    // Bevy reads an absolute path inside the scene's folder, not from the file system's root.
    let mut absolute = edited(
        "an absolute image URI, outside files allowed",
        g,
        error("Bevy reads an absolute path inside the scene's folder"),
        textured("/etc/hostname"),
    );
    absolute.args.push("--allow-outside-files".into());
    cases.push(absolute);
    // A chain of nodes 1 000 deep (Bevy's loader recurses per level).
    for (depth, expect) in [(1000, error("levels deep")), (100, Expect::Image)] {
        cases.push(edited(
            &format!("a node chain {depth} deep"),
            g,
            expect,
            |s| {
                let nodes = s["nodes"].as_array_mut().unwrap();
                let first = nodes.len();
                for i in 0..depth {
                    let child = if i + 1 < depth {
                        json!({"children": [first + i + 1]})
                    } else {
                        json!({"mesh": 0})
                    };
                    nodes.push(child);
                }
                set(s, "/scenes/0/nodes", json!([1, 2, first]));
            },
        ));
    }
    cases.extend(glb_cases());
    cases
}

fn glb_cases() -> Vec<Case> {
    let g = "GLB";
    let (positions, normals, indices) = geometry();
    let bytes = buffer(&positions, &normals, &indices);
    let mut json = scene_over(&bytes, positions.len(), indices.len(), String::new());
    json["buffers"][0].as_object_mut().unwrap().remove("uri");
    let good = glb(&json, Some(&bytes));
    let file = |name: &str, data: Vec<u8>, expect| {
        Case::new(
            name,
            g,
            vec![("scene.glb".into(), data)],
            render("scene.glb"),
            expect,
        )
    };
    let mut bad_version = good.clone();
    bad_version[4] = 7;
    let mut bad_chunk = good.clone();
    bad_chunk[16..20].copy_from_slice(b"JSOX");
    vec![
        file("a valid GLB", good.clone(), Expect::Image),
        file(
            "a GLB cut in half",
            good[..good.len() / 2].to_vec(),
            error("is not valid glTF"),
        ),
        file(
            "a GLB of container version 7",
            bad_version,
            error("is not valid glTF"),
        ),
        file(
            "a GLB whose first chunk is not JSON",
            bad_chunk,
            error("is not valid glTF"),
        ),
        file(
            "a GLB with no binary chunk",
            glb(&json, None),
            error("is not valid glTF"),
        ),
        file(
            "a GLB binary chunk too short",
            glb(&json, Some(&bytes[..64])),
            error("is not valid glTF"),
        ),
        file(
            "a GLB of 12 bytes",
            good[..12].to_vec(),
            error("is not valid glTF"),
        ),
        file(
            "a GLB whose JSON is garbage",
            glb(&json!("x"), Some(&bytes)),
            error("is not valid glTF"),
        ),
        Case::new(
            "a buffer in a .bin file beside it",
            g,
            vec![
                (
                    "scene.gltf".into(),
                    json_bytes(&scene_over(
                        &bytes,
                        positions.len(),
                        indices.len(),
                        "data.bin".into(),
                    )),
                ),
                ("data.bin".into(), bytes.clone()),
            ],
            render("scene.gltf"),
            Expect::Image,
        ),
    ]
}
