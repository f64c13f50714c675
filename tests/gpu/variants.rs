//! Suite scenes seen otherwise, as assets the renderer never saw come: placed through a
//! mirroring node, or through an orthographic camera (an isometric view). Each variant is
//! made from the scene's glTF here, as `tools/variant.py` makes it for the references.

use bevy_rppm_cli::image_io::{energy_ratio, relmse};
use serde_json::{Value, json};

use crate::util::*;

fn suite() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/suite")
}

/// `scene` from the suite, changed by `edit`, written with its textures into a folder of its
/// own; rendered at 64², 16 iterations of 65 536 photons.
fn render_variant(scene: &str, name: &str, edit: impl FnOnce(&mut Value)) -> RgbImage {
    let dir = temp(name);
    std::fs::create_dir_all(dir.join("textures")).unwrap();
    for entry in std::fs::read_dir(suite().join("textures")).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, dir.join("textures").join(path.file_name().unwrap())).unwrap();
    }
    let source = std::fs::read_to_string(suite().join(format!("{scene}.gltf"))).unwrap();
    let mut gltf: Value = serde_json::from_str(&source).unwrap();
    edit(&mut gltf);
    let path = dir.join("scene.gltf");
    std::fs::write(&path, serde_json::to_string(&gltf).unwrap()).unwrap();
    render_gltf_64(path, 16)
}

fn reference(name: &str) -> RgbImage {
    let image = read_exr(&suite().join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
    let factor = image.width / 64;
    downsample(&image, factor)
}

fn assert_close(image: &RgbImage, reference: &RgbImage, bar: f64, name: &str) {
    let energy = energy_ratio(image, reference).unwrap();
    let error = relmse(image, reference).unwrap();
    println!("{name}: energy {energy:.4}, relMSE {error:.4} after 16 iterations at 64²");
    assert!(
        (0.97..=1.03).contains(&energy) && error < bar,
        "{name}: energy {energy:.4}, relMSE {error:.4}"
    );
}

/// The root nodes that hold meshes, and the others (lights, the camera).
fn roots(gltf: &Value) -> (Vec<u64>, Vec<u64>) {
    let roots = gltf["scenes"][0]["nodes"].as_array().unwrap();
    roots
        .iter()
        .map(|n| n.as_u64().unwrap())
        .partition(|&n| gltf["nodes"][n as usize].get("mesh").is_some())
}

/// A textured asset placed through a mirroring transform (a node scaled by −1 in x, as
/// modelling tools make symmetric halves) renders as the mirror image of the asset: its
/// texture coordinates and vertex colours follow the corners that placement swaps to keep
/// the front in front (before: the checker, the cut-out's holes and the wall's colours came
/// out sheared along each triangle's diagonal, relMSE 0.71 here).
#[test]
fn a_mirrored_textured_asset_renders_as_the_mirror_image() {
    let image = render_variant("textured_box", "mirrored_textured_box", |gltf| {
        let (meshes, mut rest) = roots(gltf);
        let nodes = gltf["nodes"].as_array_mut().unwrap();
        // The light moves to the mirrored place; the camera stands on x = 0 and turns about
        // x, so it stays.
        for &n in &rest {
            let node = &mut nodes[n as usize];
            if node.get("camera").is_some() {
                assert_eq!(node["translation"][0].as_f64(), Some(0.0));
            } else if let Some(x) = node["translation"][0].as_f64() {
                node["translation"][0] = (-x).into();
            }
        }
        nodes.push(json!({ "scale": [-1.0, 1.0, 1.0], "children": meshes }));
        rest.push(nodes.len() as u64 - 1);
        gltf["scenes"][0]["nodes"] = rest.into();
    });
    let mut mirrored = reference("textured_box.ref.exr");
    for row in mirrored.pixels.chunks_mut(mirrored.width) {
        row.reverse();
    }
    assert_close(&image, &mirrored, 0.015, "mirrored textured_box");
}

/// An orthographic camera (Bevy's glTF loader makes its view `xmag` wide) over rough metal
/// spheres: camera paths leave the view's surfaces along its parallel rays, not toward the
/// camera's position (before: the spheres reflected the room as a perspective camera at the
/// same place sees it, relMSE 0.0170 here, 0.0034 now). Its reference is
/// `tools/variant.py orthographic assets/suite/glossy_metal.gltf … --width 2.2`.
#[test]
fn an_orthographic_view_of_rough_metal_matches_its_reference() {
    let image = render_variant("glossy_metal", "orthographic_glossy_metal", |gltf| {
        gltf["cameras"] = json!([{ "type": "orthographic", "orthographic":
            { "xmag": 2.2, "ymag": 2.2, "znear": 0.05, "zfar": 100.0 } }]);
    });
    let reference = reference("glossy_metal.orthographic.ref.exr");
    assert_close(&image, &reference, 0.01, "orthographic glossy_metal");
}
