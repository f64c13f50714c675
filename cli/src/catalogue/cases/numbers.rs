//! Numbers out of range, cameras, materials, lights; big and degenerate scenes.

use std::f64::consts::FRAC_1_SQRT_2;

use serde_json::{Value, json};

use super::{edited, error, json_bytes, render, set};
use crate::catalogue::scene::{buffer, data_uri, geometry, scene_over};
use crate::catalogue::{Case, Expect};

/// Numbers, cameras, materials and lights.
pub fn numbers() -> Vec<Case> {
    let g = "numbers";
    let bad = "is not valid glTF";
    let mut cases: Vec<Case> = [
        ("a translation of 1e39", "/nodes/0/translation", json!([1e39, 0.0, 0.0])),
        ("a base colour of 1e39", "/materials/0/pbrMetallicRoughness/baseColorFactor", json!([5.0, -1.0, 1e39, 1.0])),
        ("a light intensity of 1e39", "/extensions/KHR_lights_punctual/lights/0/intensity", json!(1e39)),
        ("a scale of -1e300", "/nodes/0/scale", json!([-1e300, 1.0, 1.0])),
        ("camera yfov 1e39", "/cameras/0/perspective/yfov", json!(1e39)),
        ("camera yfov 0", "/cameras/0/perspective/yfov", json!(0.0)),
        ("camera yfov π", "/cameras/0/perspective/yfov", json!(std::f64::consts::PI)),
        ("camera yfov negative", "/cameras/0/perspective/yfov", json!(-0.5)),
        ("camera znear 0", "/cameras/0/perspective/znear", json!(0.0)),
        ("camera zfar before znear", "/cameras/0/perspective/zfar", json!(0.01)),
        ("camera aspect ratio -1", "/cameras/0/perspective/aspectRatio", json!(-1.0)),
        ("an orthographic camera of zeros", "/cameras/0", json!({"type": "orthographic", "orthographic": {"xmag": 0.0, "ymag": 0.0, "znear": 0.0, "zfar": 0.0}})),
        ("an orthographic camera, zfar before znear", "/cameras/0", json!({"type": "orthographic", "orthographic": {"xmag": 3.0, "ymag": 3.0, "znear": 5.0, "zfar": 1.0}})),
        ("a camera node of scale 0", "/nodes/2/scale", json!([0.0, 0.0, 0.0])),
        ("a camera node of a zero matrix", "/nodes/2", json!({"camera": 0, "matrix": vec![0.0; 16]})),
        ("a camera without a projection", "/cameras/0", json!({"type": "perspective"})),
        ("a light of an unknown type", "/extensions/KHR_lights_punctual/lights/0/type", json!("laser")),
        ("a light radius of -1", "/extensions/KHR_lights_punctual/lights/0/extras", json!({"rppm_radius": -1.0})),
        ("a light radius that is text", "/extensions/KHR_lights_punctual/lights/0/extras", json!({"rppm_radius": "big"})),
        ("a diffuse transmission of 2", "/materials/0/extensions", json!({"KHR_materials_diffuse_transmission": {"diffuseTransmissionFactor": 2.0}})),
        ("a diffuse transmission that is text", "/materials/0/extensions", json!({"KHR_materials_diffuse_transmission": {"diffuseTransmissionFactor": "half"}})),
    ]
    .into_iter()
    .map(|(name, pointer, value)| edited(name, g, error(bad), move |s| set(s, pointer, value)))
    .collect();
    // Out of range but finite: clamped, rendered, never a NaN pixel.
    let clamped: Vec<(&str, &str, Value)> = vec![
        (
            "a base colour of [5, -1, 1]",
            "/materials/0/pbrMetallicRoughness/baseColorFactor",
            json!([5.0, -1.0, 1.0, 1.0]),
        ),
        (
            "metallic 7, roughness -3",
            "/materials/0/pbrMetallicRoughness",
            json!({"metallicFactor": 7.0, "roughnessFactor": -3.0}),
        ),
        (
            "an emissive factor of 1e30",
            "/materials/0/emissiveFactor",
            json!([1e30, 1e30, 1e30]),
        ),
        (
            "a sphere light of radius 1e6, around the scene",
            "/extensions/KHR_lights_punctual/lights/0/extras",
            json!({"rppm_radius": 1e6}),
        ),
        (
            "a light intensity of 0",
            "/extensions/KHR_lights_punctual/lights/0/intensity",
            json!(0.0),
        ),
        (
            "a negative light intensity",
            "/extensions/KHR_lights_punctual/lights/0/intensity",
            json!(-400.0),
        ),
        (
            "a light intensity of 1e30",
            "/extensions/KHR_lights_punctual/lights/0/intensity",
            json!(1e30),
        ),
        (
            "a light colour of [-1, 2, 1e30]",
            "/extensions/KHR_lights_punctual/lights/0/color",
            json!([-1.0, 2.0, 1e30]),
        ),
        (
            "a spot light whose inner cone passes its outer",
            "/extensions/KHR_lights_punctual/lights/0",
            json!({"type": "spot", "intensity": 400.0, "spot": {"innerConeAngle": 1.5, "outerConeAngle": 0.1}}),
        ),
        (
            "a light range of 0",
            "/extensions/KHR_lights_punctual/lights/0/range",
            json!(0.0),
        ),
        (
            "a clearcoat of 5 and roughness -1",
            "/materials/0/extensions",
            json!({"KHR_materials_clearcoat": {"clearcoatFactor": 5.0, "clearcoatRoughnessFactor": -1.0}}),
        ),
        (
            "a specular colour of [1000, -1, 0]",
            "/materials/0/extensions",
            json!({"KHR_materials_specular": {"specularColorFactor": [1000.0, -1.0, 0.0]}}),
        ),
        (
            "alpha cutoff -1",
            "/materials/0",
            json!({"alphaMode": "MASK", "alphaCutoff": -1.0}),
        ),
        (
            "a mesh with no primitives",
            "/meshes/0/primitives",
            json!([]),
        ),
        (
            "a mesh node of scale 0",
            "/nodes/0/scale",
            json!([0.0, 0.0, 0.0]),
        ),
        (
            "a mesh node of scale 1e-30",
            "/nodes/0/scale",
            json!([1e-30, 1e-30, 1e-30]),
        ),
        (
            "a mesh node of scale 1e30",
            "/nodes/0/scale",
            json!([1e30, 1e30, 1e30]),
        ),
        (
            "a mesh node 1e30 away",
            "/nodes/0/translation",
            json!([1e30, 0.0, 0.0]),
        ),
        (
            "a rotation of zeros",
            "/nodes/0/rotation",
            json!([0.0, 0.0, 0.0, 0.0]),
        ),
        (
            "a rotation of length 1000",
            "/nodes/0/rotation",
            json!([0.0, 1000.0, 0.0, 0.0]),
        ),
        (
            "a mesh node of a singular matrix",
            "/nodes/0/matrix",
            json!([
                1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0
            ]),
        ),
        (
            "a camera yfov of 3.1",
            "/cameras/0/perspective/yfov",
            json!(3.1),
        ),
        (
            "a camera yfov of 0.001",
            "/cameras/0/perspective/yfov",
            json!(0.001),
        ),
        (
            "a camera zfar of 1e30",
            "/cameras/0/perspective/zfar",
            json!(1e30),
        ),
        (
            "an orthographic camera",
            "/cameras/0",
            json!({"type": "orthographic", "orthographic": {"xmag": 3.0, "ymag": 3.0, "znear": 0.01, "zfar": 50.0}}),
        ),
        (
            "an ior of 0.5",
            "/materials/0/extensions",
            json!({"KHR_materials_ior": {"ior": 0.5}, "KHR_materials_transmission": {"transmissionFactor": 1.0}}),
        ),
        (
            "an ior of 1e30",
            "/materials/0/extensions",
            json!({"KHR_materials_ior": {"ior": 1e30}, "KHR_materials_transmission": {"transmissionFactor": 1.0}}),
        ),
        (
            "a transmission of 5",
            "/materials/0/extensions",
            json!({"KHR_materials_transmission": {"transmissionFactor": 5.0}}),
        ),
        (
            "a light intensity of 3e38",
            "/extensions/KHR_lights_punctual/lights/0/intensity",
            json!(3e38),
        ),
        ("no lights and nothing emissive", "/nodes/1", json!({})),
        (
            "no camera (a default one)",
            "/scenes/0/nodes",
            json!([0, 1]),
        ),
        (
            "points instead of triangles",
            "/meshes/0/primitives/0/mode",
            json!(0),
        ),
        (
            "lines instead of triangles",
            "/meshes/0/primitives/0/mode",
            json!(1),
        ),
        // Its indices read as a strip: other triangles, rendered as Bevy renders them.
        ("a triangle strip", "/meshes/0/primitives/0/mode", json!(5)),
        ("an empty scene", "/scenes/0/nodes", json!([])),
    ];
    cases.extend(clamped.into_iter().map(|(name, pointer, value)| {
        edited(name, g, Expect::Image, move |s| set(s, pointer, value))
    }));
    // Emission of 1e30, and near f32's largest on a surface the box lights back (their sums
    // overflowed to infinite pixels before emission was clamped). Bevy's loader reads the
    // strength only where the extension is declared.
    for strength in [1e30, 3.4e38] {
        cases.push(edited(
            &format!("an emission of {strength:e}"),
            g,
            Expect::Image,
            |s| {
                let used = json!(["KHR_lights_punctual", "KHR_materials_emissive_strength"]);
                set(s, "/extensionsUsed", used);
                let extension =
                    json!({"KHR_materials_emissive_strength": {"emissiveStrength": strength}});
                set(s, "/materials/0/emissiveFactor", json!([1.0, 1.0, 1.0]));
                set(s, "/materials/0/extensions", extension);
            },
        ));
    }
    // Bevy's loader turns fans down (wgpu draws none).
    cases.push(edited(
        "a triangle fan",
        g,
        error("unsupported primitive mode"),
        |s| set(s, "/meshes/0/primitives/0/mode", json!(6)),
    ));
    cases
}

/// Scenes of many lights, many triangles and degenerate geometry.
pub fn big() -> Vec<Case> {
    let g = "big";
    let lights = |n: usize| {
        move |s: &mut Value| {
            let all: Vec<Value> = (0..n).map(|i| if i % 2 == 0 {
                json!({"type": "point", "intensity": 400.0 / n as f64})
            } else {
                json!({"type": "spot", "intensity": 400.0 / n as f64, "spot": {"outerConeAngle": 0.7}})
            }).collect();
            set(s, "/extensions/KHR_lights_punctual/lights", json!(all));
            let nodes = s["nodes"].as_array_mut().unwrap();
            let first = nodes.len();
            for i in 0..n {
                let a = i as f64 * 2.399963;
                nodes.push(json!({"extensions": {"KHR_lights_punctual": {"light": i}},
                    "translation": [1.5 * a.cos(), 2.0 + (i % 7) as f64 * 0.1, 1.5 * a.sin()],
                    "rotation": [-FRAC_1_SQRT_2, 0.0, 0.0, FRAC_1_SQRT_2]}));
            }
            set(
                s,
                "/scenes/0/nodes",
                json!((0..first).chain(first..first + n).collect::<Vec<_>>()),
            );
        }
    };
    let mut cases = vec![
        edited("10 lights", g, Expect::Image, lights(10)),
        edited("100 lights", g, Expect::Image, lights(100)),
        edited("1 000 lights", g, Expect::Image, lights(1000)).slow(),
    ];
    // Every vertex at one point; NaN and infinite positions (which JSON cannot hold).
    let (positions, normals, indices) = geometry();
    let broken = |value: f32| {
        let mut p = positions.clone();
        p[5] = [value, 0.0, value];
        p
    };
    for (name, vertices) in [
        (
            "all triangles degenerate",
            vec![[0.25f32, 0.5, 0.0]; positions.len()],
        ),
        ("NaN vertex positions", broken(f32::NAN)),
        ("infinite vertex positions", broken(f32::INFINITY)),
    ] {
        let bytes = buffer(&vertices, &normals, &indices);
        let scene = scene_over(&bytes, vertices.len(), indices.len(), data_uri(&bytes));
        let files = vec![("scene.gltf".into(), json_bytes(&scene))];
        cases.push(Case::new(
            name,
            g,
            files,
            render("scene.gltf"),
            Expect::Image,
        ));
    }
    // Instancing: 170 000 instances of the 14-triangle scene mesh make 2.4 million triangles
    // (124 MB packed: inside llvmpipe's 128 MiB storage binding).
    for (name, instances, slow) in [
        ("20 000 instances", 20_000usize, false),
        ("2 million triangles by instancing", 170_000, true),
    ] {
        let case = edited(name, g, Expect::Image, move |s| {
            let nodes = s["nodes"].as_array_mut().unwrap();
            let first = nodes.len();
            let side = (instances as f64).sqrt().ceil() as usize;
            for i in 0..instances {
                let (x, z) = ((i % side) as f64, (i / side) as f64);
                nodes.push(json!({"mesh": 0, "translation": [x * 5.0, 0.0, -z * 5.0], "scale": [0.2, 0.2, 0.2]}));
            }
            set(
                s,
                "/scenes/0/nodes",
                json!(
                    (0..first)
                        .chain(first..first + instances)
                        .collect::<Vec<_>>()
                ),
            );
        });
        cases.push(if slow { case.slow() } else { case });
    }
    cases
}
