use super::util::*;

#[test]
fn extraction_gives_world_space_triangles() {
    let mut app = gpu_app();
    let world = app.world_mut();
    let cuboid = Mesh::from(Cuboid::new(1.0, 2.0, 3.0));
    let cuboid_positions: Vec<[f32; 3]> = match cuboid.attribute(Mesh::ATTRIBUTE_POSITION) {
        Some(bevy::mesh::VertexAttributeValues::Float32x3(p)) => p.clone(),
        _ => unreachable!(),
    };
    let cuboid_indices: Vec<usize> = cuboid.indices().unwrap().iter().collect();
    let transform = Transform::from_xyz(1.0, -2.0, 3.0)
        .with_rotation(Quat::from_euler(EulerRot::XYZ, 0.3, -1.1, 0.7))
        .with_scale(Vec3::new(2.0, 0.5, 1.5));
    // A square as glTF's TRIANGLE_STRIP gives it (Bevy renders strips; they used to be left
    // out), facing +Y.
    let mut strip = Mesh::new(
        PrimitiveTopology::TriangleStrip,
        RenderAssetUsages::default(),
    );
    strip.insert_attribute(
        Mesh::ATTRIBUTE_POSITION,
        vec![
            [-1.0, 0.0, -1.0],
            [-1.0, 0.0, 1.0],
            [1.0, 0.0, -1.0],
            [1.0, 0.0, 1.0],
        ],
    );
    let (m_cuboid, m_u16, m_plain, m_strip) = {
        let mut meshes = world.resource_mut::<Assets<Mesh>>();
        (
            meshes.add(cuboid),
            meshes.add(quad(1.0, Some(Indices::U16(vec![0, 1, 2, 0, 2, 3])), true)),
            meshes.add(quad(2.0, None, false)),
            meshes.add(strip),
        )
    };
    let material = matte(&mut world.resource_mut::<Assets<StandardMaterial>>(), 0.5);
    world.spawn((
        Mesh3d(m_cuboid),
        MeshMaterial3d(material.clone()),
        transform,
    ));
    world.spawn((
        Mesh3d(m_u16),
        MeshMaterial3d(material.clone()),
        Transform::from_xyz(0.0, 5.0, 0.0),
    ));
    world.spawn((
        Mesh3d(m_plain),
        MeshMaterial3d(material.clone()),
        Transform::from_xyz(0.0, -5.0, 0.0),
    ));
    world.spawn((
        Mesh3d(m_strip),
        MeshMaterial3d(material),
        Transform::from_xyz(0.0, 10.0, 0.0),
    ));
    frames(&mut app, 3);
    let scene = app.world().resource::<RppmScene>().data.clone();
    assert_eq!(
        scene.triangle_count(),
        12 + 2 + 2 + 2,
        "cuboid 12, u16 quad 2, unindexed quad 2, strip 2"
    );
    assert_eq!(scene.materials.len(), 1);
    // The cuboid's triangles, transformed on the CPU, must be in the table (order of entities
    // is not fixed, so look them up).
    let affine = transform.compute_affine();
    for tri in cuboid_indices.chunks(3) {
        let expected =
            [0, 1, 2].map(|k| affine.transform_point3(Vec3::from(cuboid_positions[tri[k]])));
        let found = scene.world_triangles().iter().any(|t| {
            t.positions()
                .iter()
                .zip(&expected)
                .all(|(a, b)| a.distance(*b) < 1e-5)
        });
        assert!(found, "transformed cuboid triangle {expected:?} missing");
    }
    // The quad and the strip without normals get flat normals, pointing up for their winding.
    for height in [-5.0, 10.0] {
        let flat: Vec<_> = scene
            .world_triangles()
            .into_iter()
            .filter(|t| t.position_a[1] == height)
            .collect();
        assert_eq!(flat.len(), 2);
        for t in flat {
            for n in [t.normal_a, t.normal_b, t.normal_c] {
                assert!(Vec3::from(n).distance(Vec3::Y) < 1e-6, "flat normal {n:?}");
            }
        }
    }
}

#[test]
fn moving_an_entity_resets_accumulation() {
    let mut app = gpu_app();
    let (camera, plane) = lit_plane(&mut app, 1000.0, 2.0, 32);
    for _ in 0..100 {
        if iteration(&app, camera) >= 4 {
            break;
        }
        app.update();
    }
    let before = iteration(&app, camera);
    assert!(before >= 4, "iterations should accumulate, got {before}");
    let store = app.world().resource::<bevy::diagnostic::DiagnosticsStore>();
    let published = store
        .get(&bevy_rppm::stats::diagnostics::ITERATIONS)
        .and_then(|d| d.value())
        .unwrap_or(0.0);
    assert!(
        published >= 1.0,
        "rppm/iterations in DiagnosticsStore: {published}"
    );
    frames(&mut app, 2);
    let still = iteration(&app, camera);
    assert!(
        still > before,
        "a frame without change must not reset ({before} -> {still})"
    );
    let epoch = app.world().resource::<RppmStats>().views[&camera].epoch;
    app.world_mut()
        .get_mut::<Transform>(plane)
        .unwrap()
        .translation
        .y = 0.1;
    frames(&mut app, 3);
    let after = iteration(&app, camera);
    let new_epoch = app.world().resource::<RppmStats>().views[&camera].epoch;
    assert!(
        after < still,
        "moving the plane must reset accumulation ({still} -> {after})"
    );
    assert!(
        new_epoch > epoch,
        "epoch must advance ({epoch} -> {new_epoch})"
    );
    // Moving the camera resets too.
    frames(&mut app, 4);
    let settled = iteration(&app, camera);
    app.world_mut()
        .get_mut::<Transform>(camera)
        .unwrap()
        .translation
        .x = 0.01;
    frames(&mut app, 3);
    assert!(
        iteration(&app, camera) < settled,
        "moving the camera must reset accumulation"
    );
}

#[test]
fn bad_input_is_left_out_without_a_panic() {
    let mut app = gpu_app();
    // A zero-power light: nothing emits, so no photon passes run.
    let light = (
        PointLight {
            intensity: 0.0,
            ..default()
        },
        Transform::from_xyz(0.0, 1.0, 0.0),
    );
    let (camera, _) = plane_scene(&mut app, light, 16, PhotonMapping::default());
    let world = app.world_mut();
    let material = matte(&mut world.resource_mut::<Assets<StandardMaterial>>(), 0.5);
    let degenerate = {
        let mut mesh = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::default(),
        );
        mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, vec![[0.0, 0.0, 0.0]; 3]);
        world.resource_mut::<Assets<Mesh>>().add(mesh)
    };
    let lines = {
        let mut mesh = Mesh::new(PrimitiveTopology::LineList, RenderAssetUsages::default());
        mesh.insert_attribute(
            Mesh::ATTRIBUTE_POSITION,
            vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]],
        );
        world.resource_mut::<Assets<Mesh>>().add(mesh)
    };
    let cube = world.resource_mut::<Assets<Mesh>>().add(Cuboid::default());
    world.spawn((Mesh3d(degenerate), MeshMaterial3d(material.clone())));
    world.spawn((Mesh3d(lines), MeshMaterial3d(material.clone())));
    world.spawn((
        Mesh3d(cube),
        MeshMaterial3d(material),
        Transform::from_xyz(f32::NAN, 0.0, 0.0),
    ));
    for _ in 0..100 {
        app.update();
        if iteration(&app, camera) >= 2 {
            break;
        }
    }
    let scene = app.world().resource::<RppmScene>().data.clone();
    assert_eq!(
        scene.triangle_count(),
        2,
        "only the plane's triangles remain"
    );
    assert!(scene.lights.is_empty(), "a zero-power light emits nothing");
    let stats = app.world().resource::<RppmStats>().views[&camera].clone();
    assert!(stats.iteration >= 2 && stats.error.is_none(), "{stats:?}");
    assert_eq!(stats.photons_per_iteration, 0, "no light, no photons");
    assert!(
        !stats.memory.contains_key("photons"),
        "no photon store without lights"
    );
    let image = app.world().resource::<RppmRadiance>().images[&camera].clone();
    // Nothing emits: the estimate is black, and finite.
    assert!(
        image
            .pixels
            .iter()
            .all(|p| p[..3].iter().all(|v| *v == 0.0))
    );
}
