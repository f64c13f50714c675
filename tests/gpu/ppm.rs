use super::util::*;

#[test]
fn photon_mapping_converges_towards_the_reference() {
    use bevy_rppm_cli::image_io::{energy_ratio, relmse};
    let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
    let reference = downsample(&read_exr(&assets.join("cornell_box.ref.exr")).unwrap(), 4);
    let settings = PhotonMapping {
        photons_per_iteration: PhotonCount::Fixed(8192),
        ..default()
    };
    let render = |iterations: u32| render_asset(settings.clone(), 64, 64, iterations);
    let few = render(2);
    let many = render(16);
    assert!(many.stats.photons_stored > 0, "no photon was stored");
    let (e_few, e_many) = (
        relmse(&few.image, &reference).unwrap(),
        relmse(&many.image, &reference).unwrap(),
    );
    let energy = energy_ratio(&many.image, &reference).unwrap();
    eprintln!(
        "photon mapping 64x64: relMSE {e_few:.4} after 2 iterations, {e_many:.4} after 16; energy ratio {energy:.3}"
    );
    assert_eq!(bad_pixels(&many.image), 0);
    assert!(
        e_many < e_few,
        "error must fall with iterations ({e_few} -> {e_many})"
    );
    assert!(e_many < 0.05, "relMSE {e_many} after 16 iterations");
    assert!((0.95..1.08).contains(&energy), "energy ratio {energy}");
}

#[test]
fn error_falls_faster_than_the_square_root_of_iterations() {
    use bevy_rppm_cli::image_io::relmse;
    let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
    let reference = downsample(&read_exr(&assets.join("cornell_box.ref.exr")).unwrap(), 4);
    // Few photons and a small radius: the variance term dominates, as it does in the long run
    // (the shipped reference also differs by Bevy's 4% specular layer, a floor near 0.003).
    let settings = PhotonMapping {
        photons_per_iteration: PhotonCount::Fixed(1024),
        initial_radius: InitialRadius::Pixels(2.0),
        ..default()
    };
    let points: Vec<(f64, f64)> = [4u32, 16, 64]
        .iter()
        .map(|&n| {
            let e = relmse(&render_box(settings.clone(), 64, n), &reference).unwrap();
            ((n as f64).ln(), e.ln())
        })
        .collect();
    let slope = (points[2].1 - points[0].1) / (points[2].0 - points[0].0);
    eprintln!("relMSE against iterations {points:?}: log-log slope {slope:.3}");
    assert!(slope < -0.5, "log-log slope {slope}");
}

#[test]
fn radius_and_mean_stay_finite_fast_forwarded_to_1e8_iterations() {
    for alpha in [1e-4f32, 0.7, 1.0] {
        let mut app = gpu_app();
        let settings = PhotonMapping { alpha, ..default() };
        let (camera, _) = plane_scene(
            &mut app,
            (
                PointLight {
                    intensity: 2000.0,
                    ..default()
                },
                Transform::from_xyz(0.0, 1.5, 0.0),
            ),
            24,
            settings.clone(),
        );
        until_iterations(&mut app, camera, 2);
        for target in [1_000_000u32, 100_000_000] {
            let ff = bevy_rppm::RppmFastForward(target);
            app.world_mut().entity_mut(camera).insert(ff);
            until_iterations(&mut app, camera, target + 2);
            let stats = app.world().resource::<RppmStats>().views[&camera].clone();
            let radius = stats.splat_radius_pixels;
            // The default radius of the 24-pixel view.
            let photons = settings.photons_per_iteration.max();
            let initial = settings.initial_radius.pixels(UVec2::splat(24), photons) as f64;
            let expected =
                bevy_rppm::radius2_after(initial * initial, stats.iteration, alpha).sqrt();
            eprintln!(
                "α {alpha}: iteration {}, radius {radius:.3e} px",
                stats.iteration
            );
            assert!(radius.is_finite() && radius > 0.0 && radius <= initial);
            assert!(
                (radius / expected - 1.0).abs() < 1e-9,
                "{radius} vs {expected}"
            );
            assert_finite(&radiance(&app, camera), &format!("α {alpha} at {target}"));
        }
    }
}

/// A glass ball makes the worst case every bounce (Σ pʲ with p = 1: 15 stores per photon);
/// the store starts there, so the first iteration loses nothing, then holds what the
/// iterations counted (a matte plane keeps under one per photon), read back with or without
/// waiting for the GPU (a game's frames do not wait).
#[test]
fn the_photon_store_holds_what_the_iterations_stored() {
    for wait in [true, false] {
        let mut app = gpu_app();
        let settings = PhotonMapping {
            photons_per_iteration: PhotonCount::Fixed(16_384),
            ..default()
        };
        let (camera, _) = plane_scene(&mut app, point_light_above(800.0, 1.5), 16, settings);
        let world = app.world_mut();
        if !wait {
            world.entity_mut(camera).remove::<RppmReadback>();
        }
        spawn_glass_ball(world);
        let stats = |app: &App| app.world().resource::<RppmStats>().views[&camera].clone();
        let capacity = |app: &App| stats(app).memory["photons"] / bevy_rppm::photons::PHOTON_BYTES;
        until_iterations(&mut app, camera, 1);
        let first = capacity(&app);
        assert!(first >= 15 * 16_384, "the first store holds {first}");
        frames(&mut app, 8);
        let s = stats(&app);
        let held = capacity(&app);
        assert!(s.photons_stored > 0, "wait {wait}: {s:?}");
        assert_eq!(s.photons_lost, 0, "wait {wait}");
        assert!(
            held < first / 4 && (held as f64) < 1.5 * s.photons_stored as f64 + 2048.0,
            "wait {wait}: the store holds {held} for {} stored (first {first})",
            s.photons_stored
        );
    }
}

/// `PhotonMapping::seed` picks the random numbers: one seed renders the same image twice,
/// another an independent image of the same light (the motion bench's references draw
/// another seed than its runs). A sphere light, whose shadow-ray samples are random.
#[test]
fn a_seed_picks_independent_random_numbers() {
    use bevy_rppm_cli::image_io::energy_ratio;
    let render = |seed| {
        let mut app = gpu_app();
        let (mut light, transform) = point_light_above(1000.0, 2.0);
        light.radius = 0.5;
        let settings = PhotonMapping {
            seed,
            photons_per_iteration: PhotonCount::Fixed(4096),
            max_iterations: Some(3),
            ..default()
        };
        let (camera, _) = plane_scene(&mut app, (light, transform), 24, settings);
        until_iterations(&mut app, camera, 3);
        let image = radiance(&app, camera);
        assert_eq!(image.iteration, 3);
        RgbImage::from_rgba(image.width, image.height, &image.pixels)
    };
    let (a, b, c) = (render(0), render(0), render(7));
    assert_eq!(a, b, "one seed, two images");
    assert_ne!(a, c, "another seed, the same image");
    let ratio = energy_ratio(&c, &a).unwrap();
    assert!((ratio - 1.0).abs() < 0.02, "energy ratio {ratio}");
}

/// `IterationsPerFrame::GpuMilliseconds` runs as many iterations a frame as its budget holds
/// (a software adapter's wall clock counted), up to `max`; the image is the one a frame at a
/// time renders, as every iteration draws by its own number. A budget under one iteration
/// runs one.
#[test]
fn a_frame_budget_runs_the_iterations_it_holds_and_the_same_image() {
    use bevy_rppm::IterationsPerFrame;
    let render = |iterations_per_frame| {
        let mut app = gpu_app();
        let settings = PhotonMapping {
            photons_per_iteration: PhotonCount::Fixed(4096),
            iterations_per_frame,
            max_iterations: Some(24),
            // A change while the scene loads starts all three again at one iteration.
            history: bevy_rppm::RppmHistory::Reset,
            ..default()
        };
        let (camera, _) = plane_scene(&mut app, point_light_above(1000.0, 2.0), 24, settings);
        let mut most = 0;
        for _ in 0..100 {
            if iteration(&app, camera) >= 24 {
                break;
            }
            app.update();
            let stats = app.world().resource::<RppmStats>();
            most = most.max(
                stats
                    .views
                    .get(&camera)
                    .map_or(0, |s| s.iterations_this_frame),
            );
        }
        let image = radiance(&app, camera);
        assert_eq!(image.iteration, 24);
        (
            most,
            RgbImage::from_rgba(image.width, image.height, &image.pixels),
        )
    };
    let (one, single) = render(IterationsPerFrame::Fixed(1));
    let budget = |milliseconds| IterationsPerFrame::GpuMilliseconds {
        milliseconds,
        max: 4,
    };
    let (most, batched) = render(budget(60_000.0));
    let (least, tight) = render(budget(0.1));
    assert_eq!((one, most, least), (1, 4, 1), "iterations a frame");
    assert_eq!(single, batched, "4 iterations a frame against 1");
    assert_eq!(single, tight);
}

/// A flat emitter's photons leave toward what lies in front of it (src/scene/receivers.rs):
/// the pool's sky panel is 7× the pool's area, and by its cosine 9 photons in 10 left past
/// everything (18 % of them were stored); toward the pool's bounding sphere most land. Its
/// energy against the reference is the suite's four-iteration test.
#[test]
fn a_sky_panels_photons_land_on_the_pool_under_it() {
    use bevy_rppm_cli::headless::{Budget, RenderRequest, render_gltf};
    let photons = 16_384;
    let request = RenderRequest {
        scene: Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/suite/water_pool.gltf"),
        width: 64,
        height: 64,
        budget: Budget::Iterations(2),
        settings: PhotonMapping {
            photons_per_iteration: PhotonCount::Fixed(photons),
            ..default()
        },
    };
    let stats = render_gltf(&request, |_| {}).unwrap().stats;
    let stored = stats.photons_stored as f64 / photons as f64;
    eprintln!("water_pool: {stored:.2} photons stored per photon emitted");
    assert!(stored > 0.6, "{stored:.2} stored per photon: {stats:?}");
}

/// Caustic photons (light that met only glass, mirrors and smooth metal) keep a disc of their
/// own where the photon share would widen it past its pixels (`InitialRadius::caustic_scale`):
/// at 128² with 4 096 photons the share's disc is 24 pixels, which blurs the glass slab's
/// caustic (0.0052 after 16 iterations; `cornell_glass` and `mirror_caustic` at 256² with
/// 16 384 photons: 3× the error, README), while its caustic photons are gathered over 6
/// (0.0032). (At 64² with 1 024 photons the caustic's disc holds too few to gain.)
#[test]
fn caustics_keep_their_own_disc_where_photons_are_few() {
    use bevy_rppm::InitialRadius;
    use bevy_rppm_cli::headless::{Budget, RenderRequest, render_gltf};
    use bevy_rppm_cli::image_io::relmse;
    let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/suite");
    let reference = downsample(&read_exr(&assets.join("glass_slab.ref.exr")).unwrap(), 2);
    let error = |initial_radius| {
        let request = RenderRequest {
            scene: assets.join("glass_slab.gltf"),
            width: 128,
            height: 128,
            budget: Budget::Iterations(16),
            settings: PhotonMapping {
                photons_per_iteration: PhotonCount::Fixed(4096),
                initial_radius,
                ..default()
            },
        };
        let image = render_gltf(&request, |_| {}).unwrap().image;
        assert_eq!(bad_pixels(&image), 0);
        relmse(&image, &reference).unwrap()
    };
    let share = error(InitialRadius::default());
    let whole = error(InitialRadius::Pixels(24.0));
    eprintln!(
        "glass_slab at 128², 4 096 photons: caustics over 6 pixels {share:.4}, over 24 {whole:.4}"
    );
    assert!(share < 0.8 * whole, "{share} against {whole}");
}
