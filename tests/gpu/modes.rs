use super::util::*;

#[test]
fn full_mode_writes_the_estimate_into_the_bevy_view() {
    let mut app = gpu_app();
    let (camera, _) = lit_plane(&mut app, 1000.0, 1.5, 64);
    // Exposure 1 (Bevy: 1 / (2^ev100 · 1.2)) and a frozen estimate, so the view is comparable.
    let world = app.world_mut();
    world.entity_mut(camera).insert(bevy::camera::Exposure {
        ev100: -(1.2f32).log2(),
    });
    world
        .get_mut::<PhotonMapping>(camera)
        .unwrap()
        .max_iterations = Some(2);
    let Some(bevy::camera::RenderTarget::Image(target)) =
        world.get::<bevy::camera::RenderTarget>(camera).cloned()
    else {
        panic!("the test camera renders to an image");
    };
    read_back_view(world, target.handle.clone());
    for _ in 0..100 {
        app.update();
        if iteration(&app, camera) >= 2 && app.world().resource::<TargetPixels>().0.is_some() {
            frames(&mut app, 4);
            break;
        }
    }
    let radiance = app.world().resource::<RppmRadiance>().images[&camera].clone();
    let view = app
        .world()
        .resource::<TargetPixels>()
        .0
        .clone()
        .expect("view read back");
    assert_eq!(view.len(), 64 * 64 * 4);
    let mut worst = 0i32;
    for (i, p) in radiance.pixels.iter().enumerate() {
        let expected = bevy_rppm_cli::image_io::tonemap_srgb8([p[0], p[1], p[2]]);
        for c in 0..3 {
            worst = worst.max((view[4 * i + c] as i32 - expected[c] as i32).abs());
        }
    }
    eprintln!("view vs tonemapped estimate: worst difference {worst}/255");
    assert!(
        worst <= 3,
        "the view differs from the estimate by {worst}/255"
    );
}

#[test]
fn indirect_mode_adds_our_light_to_bevys_and_off_gives_bevys_image() {
    check_gpu_adapter().unwrap_or_else(|hint| panic!("{hint}"));
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/cornell_box.gltf");
    let mut app = bevy_rppm_cli::load::load_gltf(&scene).unwrap();
    let world = app.world_mut();
    // Bevy's lights only: its default ambient term (which photon mapping replaces) would
    // saturate the view at exposure 1.
    world.insert_resource(bevy::light::GlobalAmbientLight::NONE);
    let camera = world
        .query_filtered::<Entity, With<Camera3d>>()
        .iter(world)
        .next()
        .unwrap();
    let target = offscreen_target(&mut world.resource_mut::<Assets<Image>>(), 64, 64);
    let bevy::camera::RenderTarget::Image(image) = target.clone() else {
        unreachable!()
    };
    world.entity_mut(camera).insert((
        target,
        bevy::camera::Hdr,
        bevy::camera::Exposure {
            ev100: -(1.2f32).log2(),
        },
        bevy::core_pipeline::tonemapping::Tonemapping::None,
        bevy::core_pipeline::tonemapping::DebandDither::Disabled,
        Msaa::Off,
        PhotonMapping {
            mode: bevy_rppm::RppmMode::Indirect,
            photons_per_iteration: PhotonCount::Fixed(16_384),
            max_iterations: Some(4),
            ..default()
        },
        RppmReadback,
    ));
    read_back_view(world, image.handle.clone());
    for _ in 0..200 {
        app.update();
        if iteration(&app, camera) >= 4 {
            break;
        }
    }
    frames(&mut app, 3);
    let with_gi = capture_view(&mut app);
    let ours = app.world().resource::<RppmRadiance>().images[&camera].clone();
    app.world_mut()
        .get_mut::<PhotonMapping>(camera)
        .unwrap()
        .enabled = false;
    frames(&mut app, 3);
    let without = capture_view(&mut app);
    app.world_mut().entity_mut(camera).remove::<PhotonMapping>();
    frames(&mut app, 3);
    let no_component = capture_view(&mut app);
    assert_eq!(
        without, no_component,
        "GI off must give exactly Bevy's image"
    );
    // Where nothing saturates, the view with GI is Bevy's plus our indirect estimate.
    let (mut added, mut expected, mut n) = (0.0f64, 0.0f64, 0);
    for (i, p) in ours.pixels.iter().enumerate() {
        let on: Vec<f32> = (0..3).map(|c| srgb_to_linear(with_gi[4 * i + c])).collect();
        if on.iter().any(|&v| v > 0.95) {
            continue;
        }
        for c in 0..3 {
            added += (on[c] - srgb_to_linear(without[4 * i + c])) as f64;
            expected += p[c] as f64;
        }
        n += 1;
    }
    eprintln!("indirect mode over {n} pixels: added {added:.2}, our estimate {expected:.2}");
    assert!(
        n > 1000 && expected > 1.0,
        "no indirect light to compare ({n} px, {expected})"
    );
    assert!(
        (added / expected - 1.0).abs() < 0.1,
        "added {added} against our estimate {expected}"
    );
}

/// Passes and shader paths follow the scene and settings: a matte plane compiles no
/// specular path, depth 1 runs no photon pass (its shadows are still traced), eye depth 1 no
/// importons; glass adds refraction (and panes only with parallel faces).
#[test]
fn only_the_passes_and_code_paths_the_scene_needs_run() {
    let passes = |settings: PhotonMapping, glass: bool| {
        let mut app = gpu_app();
        let (camera, _) = plane_scene(
            &mut app,
            (PointLight::default(), Transform::from_xyz(0.0, 1.5, 0.0)),
            16,
            settings,
        );
        if glass {
            spawn_glass_ball(app.world_mut());
        }
        until_iterations(&mut app, camera, 2);
        let stats = app.world().resource::<RppmStats>().views[&camera].clone();
        assert!(stats.error.is_none(), "{stats:?}");
        (stats.passes, stats.shader_paths, stats.memory)
    };
    let (plain, paths, memory) = passes(PhotonMapping::default(), false);
    assert!(
        paths.is_empty(),
        "a matte plane needs no specular path: {paths:?}"
    );
    assert!(plain.contains(&"photon_trace".to_string()), "{plain:?}");
    assert!(
        !plain.contains(&"importon_tracing".to_string()),
        "{plain:?}"
    );
    // Matte albedo 0.8: the store holds at most Σ 0.8ʲ ≈ 4 photons per emitted one, not 15.
    let store = memory["photons"] as f64 / (262_144.0 * bevy_rppm::photons::PHOTON_BYTES as f64);
    assert!(
        store < 5.0,
        "photon store holds {store:.2} photons per emitted photon"
    );
    let (one_bounce, _, memory) = passes(
        PhotonMapping {
            max_photon_depth: 1,
            tracer: bevy_rppm::RppmTracer::DeepCubemap,
            ..default()
        },
        false,
    );
    assert!(
        !one_bounce.contains(&"photon_trace".to_string()),
        "{one_bounce:?}"
    );
    assert!(!memory.contains_key("photons"));
    // Direct light alone still traces its shadows through the deep cubemap, no shadow maps.
    for pass in ["cubemap_build", "traced_shadows"] {
        assert!(one_bounce.contains(&pass.to_string()), "{one_bounce:?}");
    }
    assert!(
        !one_bounce.contains(&"shadow_maps".to_string()),
        "{one_bounce:?}"
    );
    let (glass, paths, _) = passes(PhotonMapping::default(), true);
    assert!(paths.contains(&"REFRACTION".to_string()), "{paths:?}");
    // A ball has no flat faces facing opposite ways: no light crosses it straight through.
    assert!(!paths.contains(&"PANES".to_string()), "{paths:?}");
    assert!(glass.contains(&"importon_tracing".to_string()), "{glass:?}");
    assert!(glass.contains(&"indirect_splat".to_string()), "{glass:?}");
    let (no_eye, _, _) = passes(
        PhotonMapping {
            max_eye_depth: 1,
            ..default()
        },
        true,
    );
    assert!(
        !no_eye.contains(&"importon_tracing".to_string()),
        "{no_eye:?}"
    );
    assert!(
        !no_eye.contains(&"indirect_splat".to_string()),
        "{no_eye:?}"
    );
}

/// Profiling (`profile_stages`) submits and waits for each stage alone and reports its wall
/// time per iteration, for every stage that ran; the image is the one an unprofiled render
/// gives.
#[test]
fn profiling_times_every_stage_and_leaves_the_image_alone() {
    let settings = |profile_stages| PhotonMapping {
        photons_per_iteration: PhotonCount::Fixed(16_384),
        profile_stages,
        tracer: bevy_rppm::RppmTracer::DeepCubemap,
        ..default()
    };
    let plain = render_asset(settings(false), 32, 32, 4);
    let profiled = render_asset(settings(true), 32, 32, 4);
    let wall = &profiled.stats.wall_ms_per_iteration;
    println!("wall ms per iteration: {wall:?}");
    assert!(plain.stats.wall_ms_per_iteration.is_empty());
    for stage in [
        "gbuffer",
        "cubemap_build",
        "local_illumination",
        "photon_trace",
        "splat",
        "accumulate",
    ] {
        assert!(
            wall.get(stage).is_some_and(|&ms| ms > 0.0),
            "{stage}: {wall:?}"
        );
    }
    let error = bevy_rppm_cli::image_io::relmse(&profiled.image, &plain.image).unwrap();
    assert!(error < 1e-4, "profiled against plain: relMSE {error}");
}
