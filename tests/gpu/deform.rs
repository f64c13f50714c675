//! Skinned meshes and morph targets: the traced scene follows the joints and weights.

use std::f32::consts::FRAC_PI_2;

use bevy::math::Affine3A;
use bevy::mesh::morph::{MeshMorphWeights, MorphAttributes};
use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
use bevy_rppm_cli::image_io::relmse;

use super::util::*;

/// A 2 m × 1 m plate in the xz plane at height `y`, facing up, as a 4 × 2 grid of vertices
/// (x = −1, −⅓, ⅓, 1): the left column follows joint 0, the right one joint 1, the middle
/// two blend them ⅔ : ⅓ and ⅓ : ⅔. No normals: both the skinned and the baked plate are
/// shaded with the normals of their posed faces.
fn plate(y: f32) -> Mesh {
    let xs = [-1.0, -1.0 / 3.0, 1.0 / 3.0, 1.0];
    let mut positions = Vec::new();
    let mut joints = Vec::new();
    let mut weights = Vec::new();
    for (i, &x) in xs.iter().enumerate() {
        for z in [-0.5, 0.5] {
            positions.push([x, y, z]);
            let w = i as f32 / 3.0;
            joints.push([0u16, 1, 0, 0]);
            weights.push([1.0 - w, w, 0.0, 0.0]);
        }
    }
    let mut indices = Vec::new();
    for i in 0..3u32 {
        let (a, b, c, d) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
        indices.extend([a, b, d, a, d, c]);
    }
    Mesh::new(PrimitiveTopology::TriangleList, RenderAssetUsages::all())
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
        .with_inserted_attribute(
            Mesh::ATTRIBUTE_JOINT_INDEX,
            bevy::mesh::VertexAttributeValues::Uint16x4(joints),
        )
        .with_inserted_attribute(Mesh::ATTRIBUTE_JOINT_WEIGHT, weights)
        .with_inserted_indices(Indices::U32(indices))
}

/// Linear blend skinning of `mesh`'s positions, written out here: Σ wᵢ (Jᵢ · Bᵢ⁻¹) p.
fn skinned_positions(mesh: &Mesh, joints: [Affine3A; 2]) -> Vec<Vec3> {
    let Some(bevy::mesh::VertexAttributeValues::Float32x3(p)) =
        mesh.attribute(Mesh::ATTRIBUTE_POSITION)
    else {
        unreachable!()
    };
    let Some(bevy::mesh::VertexAttributeValues::Float32x4(w)) =
        mesh.attribute(Mesh::ATTRIBUTE_JOINT_WEIGHT)
    else {
        unreachable!()
    };
    p.iter()
        .zip(w)
        .map(|(&p, w)| {
            w[0] * joints[0].transform_point3(p.into())
                + w[1] * joints[1].transform_point3(p.into())
        })
        .collect()
}

/// The plate's two joints: a root at the origin and a child at `hinge` (x = 0 on the plate),
/// turned by `angle` about −z (so the plate's right half lifts). Returns the root, the
/// child, and the skin.
fn spawn_skin(world: &mut World, hinge: Vec3, angle: f32) -> (Entity, Entity, SkinnedMesh) {
    let root = world.spawn(Transform::default()).id();
    let child = world
        .spawn((
            Transform::from_translation(hinge).with_rotation(Quat::from_rotation_z(angle)),
            ChildOf(root),
        ))
        .id();
    let bindposes = world
        .resource_mut::<Assets<SkinnedMeshInverseBindposes>>()
        .add(SkinnedMeshInverseBindposes::from(vec![
            Mat4::IDENTITY,
            Mat4::from_translation(-hinge),
        ]));
    let skin = SkinnedMesh {
        inverse_bindposes: bindposes,
        joints: vec![root, child],
    };
    (root, child, skin)
}

fn hinge_pose(hinge: Vec3, angle: f32) -> [Affine3A; 2] {
    [
        Affine3A::IDENTITY,
        Affine3A::from_rotation_translation(Quat::from_rotation_z(angle), hinge)
            * Affine3A::from_translation(-hinge),
    ]
}

fn has_triangle_near(scene: &bevy_rppm::SceneData, corners: [Vec3; 3]) -> bool {
    scene.world_triangles().iter().any(|t| {
        t.positions()
            .iter()
            .zip(&corners)
            .all(|(a, b)| a.distance(*b) < 1e-4)
    })
}

/// The traced triangles are those of linear blend skinning (the entity's own transform
/// ignored, as Bevy's renderer does), follow a joint that moves, and follow a morph target's
/// weight, whether it is given on the mesh or by a `MorphWeights` it references.
#[test]
fn skinned_and_morphed_meshes_follow_their_joints_and_weights() {
    let mut app = gpu_app();
    let world = app.world_mut();
    let hinge = Vec3::new(0.0, 1.0, 0.0);
    let (_, child, skin) = spawn_skin(world, hinge, 0.7);
    let mesh = plate(1.0);
    let expected = skinned_positions(&mesh, hinge_pose(hinge, 0.7));
    let skinned = world.resource_mut::<Assets<Mesh>>().add(mesh.clone());
    let material = matte(&mut world.resource_mut::<Assets<StandardMaterial>>(), 0.5);
    world.spawn((
        Mesh3d(skinned),
        MeshMaterial3d(material.clone()),
        skin,
        Transform::from_xyz(50.0, 0.0, 0.0),
    ));
    // A quad whose one morph target lifts every vertex by 2 m.
    let mut morphed = quad(1.0, Some(Indices::U32(vec![0, 1, 2, 0, 2, 3])), true);
    morphed.set_morph_targets(vec![
        MorphAttributes::from([
            Vec3::Y * 2.0,
            Vec3::ZERO,
            Vec3::ZERO
        ]);
        4
    ]);
    let morphed = world.resource_mut::<Assets<Mesh>>().add(morphed);
    let morph = world
        .spawn((
            Mesh3d(morphed),
            MeshMorphWeights::Value {
                weights: vec![0.25],
            },
            MeshMaterial3d(material),
            Transform::from_xyz(0.0, -5.0, 0.0),
        ))
        .id();
    frames(&mut app, 3);
    let scene = app.world().resource::<RppmScene>().data.clone();
    assert_eq!(scene.triangle_count(), 6 + 2);
    let indices = mesh.indices().unwrap().iter().collect::<Vec<_>>();
    for tri in indices.chunks(3) {
        let corners = [0, 1, 2].map(|k| expected[tri[k]]);
        assert!(
            has_triangle_near(&scene, corners),
            "skinned triangle {corners:?} missing"
        );
    }
    let morph_heights = |scene: &bevy_rppm::SceneData| -> Vec<f32> {
        scene
            .world_triangles()
            .iter()
            .flat_map(|t| t.positions())
            .filter(|p| p.y < 0.0)
            .map(|p| p.y)
            .collect()
    };
    assert!(
        morph_heights(&scene).iter().all(|y| (y + 4.5).abs() < 1e-5),
        "weight 0.25 of a 2 m lift: {:?}",
        morph_heights(&scene)
    );

    // The joint straightens: the plate is flat at y = 1 again.
    let epoch = app.world().resource::<RppmScene>().epoch;
    app.world_mut()
        .entity_mut(child)
        .insert(Transform::from_translation(hinge));
    frames(&mut app, 2);
    let scene = app.world().resource::<RppmScene>();
    assert!(scene.epoch > epoch, "a moved joint extracts again");
    let plate_ys: Vec<f32> = scene
        .data
        .world_triangles()
        .iter()
        .flat_map(|t| t.positions())
        .filter(|p| p.y > 0.0)
        .map(|p| p.y)
        .collect();
    assert!(
        plate_ys.iter().all(|y| (y - 1.0).abs() < 1e-5),
        "bind pose: {plate_ys:?}"
    );

    // Weights by reference to a `MorphWeights`, then changed there.
    let weights = app
        .world_mut()
        .spawn(bevy::mesh::morph::MorphWeights::new(vec![1.0], None).unwrap())
        .id();
    app.world_mut()
        .entity_mut(morph)
        .insert(MeshMorphWeights::Reference(weights));
    frames(&mut app, 2);
    let heights = morph_heights(&app.world().resource::<RppmScene>().data);
    assert!(
        heights.iter().all(|y| (y + 3.0).abs() < 1e-5),
        "weight 1: {heights:?}"
    );
    app.world_mut()
        .get_mut::<bevy::mesh::morph::MorphWeights>(weights)
        .unwrap()
        .weights_mut()[0] = 0.5;
    frames(&mut app, 2);
    let heights = morph_heights(&app.world().resource::<RppmScene>().data);
    assert!(
        heights.iter().all(|y| (y + 4.0).abs() < 1e-5),
        "weight 0.5: {heights:?}"
    );
}

/// A plate bent by its skin, between a light and a lit floor, casts the shadow of the same
/// plate baked in that pose (same triangles, same seeds), not the one of its bind pose.
#[test]
fn a_posed_skin_renders_as_its_pose_baked_into_a_mesh() {
    let hinge = Vec3::new(0.0, 1.0, 0.0);
    let angle = -FRAC_PI_2; // the right half stands up
    let render = |kind: &str| -> RgbImage {
        let mut app = gpu_app();
        let (camera, _) = lit_plane(&mut app, 1000.0, 2.0, 32);
        let world = app.world_mut();
        let material = matte(&mut world.resource_mut::<Assets<StandardMaterial>>(), 0.5);
        let mesh = plate(1.0);
        match kind {
            "skinned" => {
                let (_, _, skin) = spawn_skin(world, hinge, angle);
                let mesh = world.resource_mut::<Assets<Mesh>>().add(mesh);
                world.spawn((Mesh3d(mesh), MeshMaterial3d(material), skin));
            }
            _ => {
                let pose = if kind == "baked" { angle } else { 0.0 };
                let positions: Vec<[f32; 3]> = skinned_positions(&mesh, hinge_pose(hinge, pose))
                    .iter()
                    .map(Vec3::to_array)
                    .collect();
                let mut baked = mesh.clone();
                baked.insert_attribute(Mesh::ATTRIBUTE_POSITION, positions);
                // Bevy's own pipeline would skin a mesh with joints.
                baked.remove_attribute(Mesh::ATTRIBUTE_JOINT_INDEX);
                baked.remove_attribute(Mesh::ATTRIBUTE_JOINT_WEIGHT);
                let mesh = world.resource_mut::<Assets<Mesh>>().add(baked);
                world.spawn((Mesh3d(mesh), MeshMaterial3d(material), Transform::default()));
            }
        }
        estimate_after(&mut app, camera, 4, kind)
    };
    let skinned = render("skinned");
    let baked = render("baked");
    let bind = render("bind");
    let posed = relmse(&skinned, &baked).unwrap();
    let unposed = relmse(&bind, &baked).unwrap();
    println!("relMSE against the baked pose: skinned {posed:.5}, bind pose {unposed:.5}");
    assert!(posed < 0.01, "skinned against baked: {posed}");
    assert!(unposed > 10.0 * posed.max(1e-4), "bind pose: {unposed}");
}

/// Bevy's `Fox.glb`, posed by its animations through the CLI's `animation::pose`: the traced
/// triangles lie inside the bounds Bevy computes for the skinned mesh from its joints, fill
/// them, and move from pose to pose.
#[test]
fn the_fox_follows_its_animation_inside_bevys_skinned_bounds() {
    use bevy::camera::primitives::Aabb;
    use bevy::mesh::skinning::SkinnedMesh;
    use bevy_rppm_cli::load::load_gltf;
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/fox/Fox.glb");
    let posed = |animation: Option<(usize, f32)>| -> Vec<Vec3> {
        let mut app = load_gltf(&scene).unwrap_or_else(|e| panic!("{e}"));
        if let Some((index, seconds)) = animation {
            bevy_rppm_cli::animation::pose(&mut app, &scene, index, seconds)
                .unwrap_or_else(|e| panic!("{e}"));
        }
        frames(&mut app, 2);
        let world = app.world_mut();
        let (aabb, transform) = world
            .query_filtered::<(&Aabb, &GlobalTransform), With<SkinnedMesh>>()
            .single(world)
            .expect("one skinned mesh");
        let (lo, hi) = (aabb.min(), aabb.max());
        let entity_from_world = transform.affine().inverse();
        let points: Vec<Vec3> = world
            .resource::<RppmScene>()
            .data
            .world_triangles()
            .iter()
            .flat_map(|t| t.positions())
            .collect();
        assert_eq!(points.len(), 3 * 576, "the fox's triangles");
        let local: Vec<Vec3> = points
            .iter()
            .map(|&p| entity_from_world.transform_point3(p))
            .collect();
        let slack = 0.01 * Vec3::from(hi - lo).length();
        let (min, max) = local
            .iter()
            .fold((Vec3::MAX, Vec3::MIN), |(a, b), &p| (a.min(p), b.max(p)));
        let outside = local
            .iter()
            .filter(|p| {
                p.cmplt(Vec3::from(lo) - slack).any() || p.cmpgt(Vec3::from(hi) + slack).any()
            })
            .count();
        println!("{animation:?}: triangles span {min} .. {max}, Bevy's bounds {lo} .. {hi}");
        assert_eq!(
            outside, 0,
            "{animation:?}: corners outside Bevy's skinned bounds"
        );
        let filled = (max - min) / Vec3::from(hi - lo);
        assert!(
            filled.min_element() > 0.6,
            "{animation:?}: the bounds are filled {filled}"
        );
        points
    };
    let bind = posed(None);
    let walk = posed(Some((1, 0.5)));
    let run = posed(Some((2, 0.25)));
    let moved = |a: &[Vec3], b: &[Vec3]| {
        a.iter()
            .zip(b)
            .map(|(p, q)| p.distance(*q))
            .fold(0.0f32, f32::max)
    };
    let size = bind
        .iter()
        .fold((Vec3::MAX, Vec3::MIN), |(a, b), &p| (a.min(p), b.max(p)));
    let size = (size.1 - size.0).length();
    let (walked, ran) = (moved(&bind, &walk), moved(&walk, &run));
    println!("largest move: bind → walk {walked:.1}, walk → run {ran:.1} (fox size {size:.1})");
    assert!(walked > 0.05 * size && ran > 0.05 * size);
}
