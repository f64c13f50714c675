use super::util::*;

#[test]
fn a_target_resized_to_zero_and_back_keeps_rendering() {
    use bevy::camera::RenderTarget;
    let mut app = gpu_app();
    let (camera, _) = lit_plane(&mut app, 1000.0, 2.0, 32);
    until_iterations(&mut app, camera, 2);
    let Some(RenderTarget::Image(target)) = app.world().get::<RenderTarget>(camera).cloned() else {
        panic!("the camera renders to an image");
    };
    let resize = |app: &mut App, w: u32, h: u32| {
        let mut images = app.world_mut().resource_mut::<Assets<Image>>();
        let mut image = images.get_mut(&target.handle).unwrap();
        image.resize(bevy::render::render_resource::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        });
    };
    // A window resized to 0×0: Bevy drops the camera's render view (bevy_render's camera
    // extraction skips zero-sized targets; a 0×0 image target cannot be made at all), the
    // same path as an inactive camera. Nothing renders, nothing panics.
    let active = |app: &mut App, on: bool| {
        app.world_mut().get_mut::<Camera>(camera).unwrap().is_active = on;
    };
    active(&mut app, false);
    frames(&mut app, 3);
    active(&mut app, true);
    resize(&mut app, 48, 40);
    for _ in 0..40 {
        app.update();
        let image = radiance(&app, camera);
        if (image.width, image.height) == (48, 40) && image.iteration >= 2 {
            assert_finite(&image, "after resizing back");
            let lit = image.pixels.iter().filter(|p| p[1] > 0.0).count();
            assert!(lit > 48 * 40 / 2, "only {lit} lit pixels after the resize");
            return;
        }
    }
    panic!("no 48x40 estimate came back after the resize");
}

/// Every knob at both ends of its range, on the shipped Cornell box: finite, no error.
#[test]
fn extreme_settings_render_finite_images() {
    let base = PhotonMapping {
        photons_per_iteration: PhotonCount::Fixed(4096),
        ..default()
    };
    let cases: Vec<(&str, PhotonMapping)> = vec![
        (
            "0 photons",
            PhotonMapping {
                photons_per_iteration: PhotonCount::Fixed(0),
                ..base.clone()
            },
        ),
        (
            "1 photon",
            PhotonMapping {
                photons_per_iteration: PhotonCount::Fixed(1),
                ..base.clone()
            },
        ),
        (
            "photon depth 1",
            PhotonMapping {
                max_photon_depth: 1,
                ..base.clone()
            },
        ),
        (
            "photon depth 64",
            PhotonMapping {
                max_photon_depth: 64,
                ..base.clone()
            },
        ),
        (
            "eye depth 64",
            PhotonMapping {
                max_eye_depth: 64,
                ..base.clone()
            },
        ),
        (
            "cubemap 16",
            PhotonMapping {
                cubemap_resolution: 16,
                ..base.clone()
            },
        ),
        (
            "cubemap max",
            PhotonMapping {
                cubemap_resolution: 4096,
                ..base.clone()
            },
        ),
        (
            "bins 1",
            PhotonMapping {
                bins: 1,
                ..base.clone()
            },
        ),
        (
            "bins 64",
            PhotonMapping {
                bins: 64,
                ..base.clone()
            },
        ),
        (
            "tile 4",
            PhotonMapping {
                cubemap_tile_size: 4,
                ..base.clone()
            },
        ),
        (
            "alpha 1e-4",
            PhotonMapping {
                alpha: 1e-4,
                ..base.clone()
            },
        ),
        (
            "radius 0.25 px",
            PhotonMapping {
                initial_radius: InitialRadius::Pixels(0.25),
                ..base.clone()
            },
        ),
        (
            "radius 256 px",
            PhotonMapping {
                initial_radius: InitialRadius::Pixels(256.0),
                ..base.clone()
            },
        ),
        (
            "flattening 0.01",
            PhotonMapping {
                kernel_flattening: 0.01,
                ..base.clone()
            },
        ),
        (
            "subsampling 4",
            PhotonMapping {
                indirect_subsampling: 4,
                ..base.clone()
            },
        ),
    ];
    for (name, settings) in cases {
        let r = render_asset(settings, 24, 24, 3);
        eprintln!(
            "{name}: mean {:.4}, passes {:?}, {} MiB",
            r.image.mean(),
            r.stats.passes,
            r.stats.memory.values().sum::<u64>() >> 20
        );
        assert_eq!(bad_pixels(&r.image), 0, "{name}");
        assert!(r.stats.error.is_none(), "{name}: {:?}", r.stats.error);
        assert!(r.image.mean() > 0.0, "{name}: black image");
    }
}

/// Radiance is invariant under scaling the scene when a point light's intensity (W/sr)
/// scales with the area (E ∝ I/d²), and linear in the light's power.
#[test]
fn scene_scale_and_light_power_extremes_match_the_reference() {
    use bevy_rppm_cli::image_io::relmse;
    let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
    let reference = downsample(&read_exr(&assets.join("cornell_box.ref.exr")).unwrap(), 4);
    let unit = relmse(&render_transformed_box(1.0, 1.0, 64), &reference).unwrap();
    for (scale, power) in [(1e-3f32, 1.0f32), (1e4, 1.0), (1.0, 1e-6), (1.0, 1e9)] {
        // Same intensity over an s-times larger scene: radiance falls by s².
        let image = render_transformed_box(scale, power, 64);
        assert_eq!(bad_pixels(&image), 0, "scale {scale}, power {power}");
        let back = scaled(&image, scale * scale / power);
        let e = relmse(&back, &reference).unwrap();
        eprintln!("scale {scale:e} m, power ×{power:e}: relMSE {e:.4} (scale 1: {unit:.4})");
        assert!(e < unit * 1.5 + 0.005, "relMSE {e} vs {unit} at scale 1");
    }
}

/// A camera inside a closed box, rays grazing a plane, coplanar overlapping triangles and
/// degenerate ones: finite images, no error.
#[test]
fn camera_inside_geometry_and_grazing_coplanar_triangles_stay_finite() {
    let mut app = gpu_app();
    let (camera, _) = lit_plane(&mut app, 1000.0, 1.5, 24);
    let world = app.world_mut();
    let material = matte(&mut world.resource_mut::<Assets<StandardMaterial>>(), 0.5);
    let twin = world
        .resource_mut::<Assets<Mesh>>()
        .add(quad(5.0, None, true));
    world.spawn((Mesh3d(twin), MeshMaterial3d(material.clone())));
    let sliver = {
        let mut mesh = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::default(),
        );
        let p = [[0.0, 0.01, 0.0], [1.0, 0.01, 0.0], [2.0, 0.01, 1e-7]];
        mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, p.to_vec());
        world.resource_mut::<Assets<Mesh>>().add(mesh)
    };
    world.spawn((Mesh3d(sliver), MeshMaterial3d(material.clone())));
    let cube = Cuboid::new(1.0, 1.0, 1.0);
    spawn_mesh(world, cube, material, Transform::from_xyz(0.0, 0.6, 0.0));
    // Inside the cube, then level with the plane looking along it.
    let poses = [
        Transform::from_xyz(0.0, 0.6, 0.0).looking_at(Vec3::new(0.3, 0.6, 0.2), Vec3::Y),
        Transform::from_xyz(-4.0, 1e-4, 0.0).looking_at(Vec3::new(4.0, 1e-4, 0.0), Vec3::Y),
    ];
    for pose in poses {
        *app.world_mut().get_mut::<Transform>(camera).unwrap() = pose;
        frames(&mut app, 2);
        until_iterations(&mut app, camera, 2);
        let stats = app.world().resource::<RppmStats>().views[&camera].clone();
        assert!(stats.error.is_none(), "{:?}", stats.error);
        assert!(stats.iteration >= 2, "iteration {}", stats.iteration);
        assert_finite(&radiance(&app, camera), &format!("camera at {pose:?}"));
    }
}

/// In a Bevy app, malformed glTF assets (the catalogue's structure cases that Bevy's own
/// loader turns down) fail to load with an error log, and the scene around them keeps
/// rendering: the estimate goes on, finite and lit.
#[test]
fn bad_assets_leave_the_rest_of_the_scene_rendering() {
    use bevy::world_serialization::WorldAssetRoot;
    use bevy_rppm_cli::catalogue::{Expect, all_cases};
    let mut app = gpu_app();
    let (camera, _) = lit_plane(&mut app, 1000.0, 2.0, 32);
    until_iterations(&mut app, camera, 2);
    // Under the crate's asset root (the test app's), in the ignored out/.
    let folder = Path::new(env!("CARGO_MANIFEST_DIR")).join("out/bad_assets");
    let _ = std::fs::remove_dir_all(&folder);
    let mut handles = Vec::new();
    for (i, case) in all_cases()
        .into_iter()
        .filter(|c| c.group == "structure" && matches!(c.expect, Expect::Error(_)))
        .filter(|c| c.files.len() == 1 && !c.name.contains("deep"))
        .enumerate()
    {
        let file = folder.join(format!("{i:03}.gltf"));
        std::fs::create_dir_all(&folder).unwrap();
        std::fs::write(&file, &case.files[0].1).unwrap();
        let path = format!("out/bad_assets/{i:03}.gltf");
        let handle = app
            .world()
            .resource::<AssetServer>()
            .load(bevy::gltf::GltfAssetLabel::Scene(0).from_asset(path));
        app.world_mut().spawn(WorldAssetRoot(handle.clone()));
        handles.push((case.name, handle));
    }
    assert!(handles.len() >= 30, "{} bad assets", handles.len());
    let before = iteration(&app, camera);
    for _ in 0..200 {
        app.update();
        let server = app.world().resource::<AssetServer>();
        let settled = handles.iter().all(|(_, h)| {
            !matches!(
                server.get_load_state(h),
                Some(bevy::asset::LoadState::Loading)
            )
        });
        if settled && iteration(&app, camera) >= before + 4 {
            break;
        }
    }
    let server = app.world().resource::<AssetServer>();
    let loaded: Vec<&String> = handles
        .iter()
        .filter(|(_, h)| {
            matches!(
                server.get_load_state(h),
                Some(bevy::asset::LoadState::Loaded)
            )
        })
        .map(|(name, _)| name)
        .collect();
    println!("bad assets Bevy's loader accepted anyway: {loaded:?}");
    assert!(
        iteration(&app, camera) >= before + 4,
        "the estimate stopped"
    );
    let image = radiance(&app, camera);
    assert_finite(&image, "beside bad assets");
    let lit = image.pixels.iter().filter(|p| p[1] > 0.0).count();
    assert!(lit > image.pixels.len() / 2, "only {lit} lit pixels");
}

/// A target whose per-pixel buffers would pass the device's storage binding limit drops what
/// does not fit, with a warning, instead of failing: at 1700² the history
/// (`RppmHistory::Reuse`, the default: 48 bytes a pixel in one binding, 132 MiB) runs as
/// `Reset`, and the importons (64 bytes, 176 MiB; the glass ball makes them) are not made,
/// both over llvmpipe's 128 MiB.
#[test]
fn a_target_too_large_for_its_buffers_renders_without_them() {
    let mut app = gpu_app();
    let settings = PhotonMapping {
        photons_per_iteration: PhotonCount::Fixed(1024),
        ..default()
    };
    let (camera, _) = plane_scene(&mut app, point_light_above(1000.0, 2.0), 1700, settings);
    spawn_glass_ball(app.world_mut());
    until_iterations(&mut app, camera, 2);
    let limits = app
        .world()
        .resource::<bevy::render::renderer::RenderDevice>()
        .limits();
    let most = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    let fits = |bytes: u64| 1700 * 1700 * bytes <= most;
    let stats = &app.world().resource::<RppmStats>().views[&camera];
    assert_eq!(
        stats.memory.contains_key("history"),
        fits(48),
        "history held"
    );
    let importons = stats.memory["importons"];
    assert_eq!(importons >= 1700 * 1700 * 64, fits(64), "importons held");
    assert_finite(
        &radiance(&app, camera),
        "a target too large for its buffers",
    );
}
