use super::util::*;

#[test]
fn direct_light_on_a_plane_matches_the_analytic_radiance() {
    let mut app = gpu_app();
    let (lumens, height, size) = (2000.0f32, 1.5f32, 64u32);
    let (camera, _) = lit_plane(&mut app, lumens, height, size);
    frames(&mut app, 12);
    let image = app
        .world()
        .resource::<RppmRadiance>()
        .images
        .get(&camera)
        .cloned()
        .expect("radiance read back");
    assert!(image.iteration >= 4, "only {} iterations", image.iteration);
    let rgb = RgbImage::from_rgba(image.width, image.height, &image.pixels);
    assert_eq!(bad_pixels(&rgb), 0);
    let intensity = lumens / (4.0 * std::f32::consts::PI);
    let mut worst = 0.0f32;
    for j in 0..size as usize {
        for i in 0..size as usize {
            let x = -2.0 + (i as f32 + 0.5) * 4.0 / size as f32;
            let z = -2.0 + (j as f32 + 0.5) * 4.0 / size as f32;
            let d2 = x * x + z * z + height * height;
            let cos = height / d2.sqrt();
            let expected = 0.8 / std::f32::consts::PI * intensity * cos / d2;
            let got = rgb.at(i, j)[1];
            worst = worst.max((got - expected).abs() / expected);
        }
    }
    eprintln!("direct lighting: worst relative error {worst:.5} over {size}x{size} pixels");
    assert!(worst < 0.01, "worst relative error {worst}");
}

#[test]
fn photons_carry_the_same_direct_light_as_the_local_stage() {
    use bevy_rppm_cli::image_io::energy_ratio;
    let local = render_box(
        PhotonMapping {
            photons_per_iteration: PhotonCount::Fixed(0),
            ..default()
        },
        64,
        4,
    );
    // A one-pixel gather radius: wide discs blur across box edges and shadow borders, which
    // is the estimator's bias, not a flux error.
    let photons = render_box(
        PhotonMapping {
            photons_per_iteration: PhotonCount::Fixed(65_536),
            initial_radius: InitialRadius::Pixels(1.0),
            debug_view: bevy_rppm::RppmDebugView::DirectPhotons,
            ..default()
        },
        64,
        8,
    );
    let whole = energy_ratio(&photons, &local).unwrap();
    let floor = region_mean(&photons, 57..63, 10..55) / region_mean(&local, 57..63, 10..55);
    let wall = region_mean(&photons, 15..45, 1..7) / region_mean(&local, 15..45, 1..7);
    eprintln!(
        "photon direct / local direct: whole {whole:.3}, floor {floor:.3}, left wall {wall:.3}"
    );
    assert!(
        (0.88..1.05).contains(&whole),
        "whole-image energy ratio {whole}"
    );
    assert!((0.97..1.03).contains(&floor), "floor ratio {floor}");
    assert!((0.97..1.03).contains(&wall), "wall ratio {wall}");
}

#[test]
fn spot_light_on_a_plane_matches_bevys_falloff() {
    let (lumens, height, inner, outer) = (3000.0f32, 1.5f32, 0.35f32, 0.6f32);
    let light = (
        SpotLight {
            intensity: lumens,
            inner_angle: inner,
            outer_angle: outer,
            range: 100.0,
            ..default()
        },
        Transform::from_xyz(0.0, height, 0.0).looking_at(Vec3::ZERO, Vec3::Z),
    );
    let intensity = lumens / (4.0 * std::f32::consts::PI);
    check_light(
        light,
        |x, z| {
            let d2 = x * x + z * z + height * height;
            let cos = height / d2.sqrt();
            let a = ((cos - outer.cos()) / (inner.cos() - outer.cos())).clamp(0.0, 1.0);
            0.8 / std::f32::consts::PI * intensity * a * a * cos / d2
        },
        "spot",
    );
}

#[test]
fn directional_light_on_a_plane_gives_e_cos_theta() {
    let (lux, tilt) = (10.0f32, 0.5f32);
    let direction = Vec3::new(tilt.sin(), -tilt.cos(), 0.0);
    let light = (
        DirectionalLight {
            illuminance: lux,
            ..default()
        },
        Transform::default().looking_to(direction, Vec3::Z),
    );
    check_light(
        light,
        |_, _| 0.8 / std::f32::consts::PI * lux * tilt.cos(),
        "directional",
    );
}

#[test]
fn point_light_photons_carry_its_power() {
    let (lumens, height) = (2000.0f32, 1.5f32);
    let light = (
        PointLight {
            intensity: lumens,
            range: 100.0,
            ..default()
        },
        Transform::from_xyz(0.0, height, 0.0),
    );
    let intensity = lumens / (4.0 * std::f32::consts::PI);
    check_light(
        light,
        |x, z| {
            let d2 = x * x + z * z + height * height;
            0.8 / std::f32::consts::PI * intensity * height / d2.sqrt() / d2
        },
        "point",
    );
}

/// A point light with a `radius` is a sphere of the same power: on a plane entirely below it,
/// it gives the point light's irradiance (a uniform sphere's theorem), its photons carry the
/// same light, and a small occluder's hard shadow becomes a penumbra with no umbra left on
/// the floor.
#[test]
fn sphere_light_keeps_the_irradiance_and_softens_shadows() {
    let (lumens, height, size) = (2000.0f32, 1.5f32, 64u32);
    let render = |radius: f32, occluder: bool, settings: PhotonMapping| -> RgbImage {
        let mut app = gpu_app();
        let light = (
            PointLight {
                intensity: lumens,
                radius,
                range: 100.0,
                ..default()
            },
            Transform::from_xyz(0.0, height, 0.0),
        );
        let (camera, _) = plane_scene(&mut app, light, size, settings);
        // The camera under the light, whose sphere it would see (and the occluder) above it.
        let under = Transform::from_xyz(0.0, 1.0, 0.0).looking_at(Vec3::ZERO, Vec3::NEG_Z);
        app.world_mut().entity_mut(camera).insert(under);
        if occluder {
            spawn_occluder(
                &mut app,
                0.15,
                1.1,
                StandardMaterial {
                    base_color: Color::BLACK,
                    perceptual_roughness: 1.0,
                    reflectance: 0.0,
                    ..default()
                },
            );
        }
        estimate_after(&mut app, camera, 16, "sphere light")
    };
    let intensity = lumens / (4.0 * std::f32::consts::PI);
    let expected = |i: usize, j: usize| {
        let x = -2.0 + (i as f32 + 0.5) * 4.0 / size as f32;
        let z = -2.0 + (j as f32 + 0.5) * 4.0 / size as f32;
        let d2 = x * x + z * z + height * height;
        0.8 / std::f32::consts::PI * intensity * (height / d2.sqrt()) / d2
    };
    let lit = render(0.4, false, PhotonMapping::default());
    // Per 8×8 block (each pixel's sphere sample is noise: 10 % at 16 iterations).
    let (mut got, mut want, mut worst) = (0.0f64, 0.0f64, 0.0f64);
    for block in 0..(size as usize / 8).pow(2) {
        let (bi, bj) = (block % (size as usize / 8), block / (size as usize / 8));
        let (mut g, mut w) = (0.0f64, 0.0f64);
        for j in bj * 8..bj * 8 + 8 {
            for i in bi * 8..bi * 8 + 8 {
                g += lit.at(i, j)[1] as f64;
                w += expected(i, j) as f64;
            }
        }
        worst = worst.max((g / w - 1.0).abs());
        got += g;
        want += w;
    }
    let ratio = got / want;
    println!(
        "sphere light (R 0.4 m at 1.5 m): irradiance ratio {ratio:.4}, worst 8×8 block {worst:.4}"
    );
    assert!((ratio - 1.0).abs() < 0.01, "irradiance ratio {ratio}");
    assert!(worst < 0.05, "worst block {worst}");
    // Photons leave the sphere's surface with the same power (direct light by photons alone).
    let photons = render(
        0.4,
        false,
        PhotonMapping {
            photons_per_iteration: PhotonCount::Fixed(65_536),
            debug_view: bevy_rppm::RppmDebugView::DirectPhotons,
            ..default()
        },
    );
    let energy = bevy_rppm_cli::image_io::energy_ratio(&photons, &lit).unwrap();
    println!("sphere light: photon/local energy {energy:.4}");
    assert!(
        (0.97..1.03).contains(&energy),
        "photon energy ratio {energy}"
    );
    // The umbra: pixels under a tenth of the unshadowed light.
    let umbra = |image: &RgbImage| {
        (0..size as usize)
            .flat_map(|j| (0..size as usize).map(move |i| (i, j)))
            .filter(|&(i, j)| image.at(i, j)[1] < 0.1 * expected(i, j))
            .count()
    };
    let (hard, soft) = (
        umbra(&render(0.0, true, PhotonMapping::default())),
        umbra(&render(0.2, true, PhotonMapping::default())),
    );
    println!("umbra pixels: point light {hard}, sphere of radius 0.2 m {soft}");
    assert!(hard > 200 && soft * 3 < hard, "umbra {hard} → {soft}");
}

/// The plane under a slab of glass 0.2 m thick, 1.6 m square, halfway between `plane_scene`'s
/// camera and light: clear, or coloured (`KHR_materials_volume`'s attenuation: white light
/// keeps `tint` after 0.2 m inside). 32 iterations at 32².
fn plane_under_glass(tint: Option<Color>) -> RgbImage {
    let mut app = gpu_app();
    let light = point_light_above(20_000.0, 3.0);
    let settings = PhotonMapping {
        photons_per_iteration: PhotonCount::Fixed(65_536),
        history: bevy_rppm::RppmHistory::Reset,
        ..default()
    };
    let (camera, _) = plane_scene(&mut app, light, 32, settings);
    let world = app.world_mut();
    let glass = StandardMaterial {
        base_color: Color::WHITE,
        specular_transmission: 1.0,
        perceptual_roughness: 0.0,
        ior: 1.5,
        thickness: 0.2,
        attenuation_color: tint.unwrap_or(Color::WHITE),
        attenuation_distance: if tint.is_some() { 0.2 } else { f32::INFINITY },
        ..default()
    };
    let glass = world.resource_mut::<Assets<StandardMaterial>>().add(glass);
    let slab = Cuboid::new(1.6, 0.2, 1.6);
    spawn_mesh(world, slab, glass, Transform::from_xyz(0.0, 1.0, 0.0));
    estimate_after(&mut app, camera, 32, "plane under glass")
}

/// Coloured glass absorbs along the path inside it (Beer–Lambert), for photons and camera
/// paths alike: under a slab as thick as its attenuation distance, seen through it, the plane
/// keeps tint² of what it shows under clear glass (light crosses the slab once on its way
/// down, the camera's path once on its way up; at these near-normal angles the longer slant
/// paths and the interreflections inside change it by under 1 %), and the plane beside it
/// (direct light, no glass on either path) is unchanged. No channel passes whole, so photons
/// inside are ended by roulette and the survivors weighted up: the mean must hold.
#[test]
fn coloured_glass_absorbs_along_the_path_inside() {
    let tint = [0.5f32, 0.8, 0.9];
    let clear = plane_under_glass(None);
    let tinted = plane_under_glass(Some(Color::linear_rgb(tint[0], tint[1], tint[2])));
    // Under the slab's middle (±0.5 m), and beyond its shadow (|x| > 1.5 m).
    let mean = region_channel_mean;
    let mut failures = Vec::new();
    for (c, t) in tint.iter().enumerate() {
        let under = mean(&tinted, 12..20, 12..20, c) / mean(&clear, 12..20, 12..20, c);
        let beside = mean(&tinted, 0..32, 0..4, c) / mean(&clear, 0..32, 0..4, c);
        let expected = (t * t) as f64;
        eprintln!(
            "channel {c}: under the slab {under:.4} (expected {expected:.4}), beside it {beside:.4}"
        );
        if (under / expected - 1.0).abs() > 0.05 || (beside - 1.0).abs() > 0.02 {
            failures.push(format!(
                "channel {c}: under {under:.4} against {expected:.4}, beside {beside:.4}"
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The pixel-centre radiance of the plane, averaged over the same Halton jitter as the
/// renderer's first `iterations` iterations (so only numerical error remains). The jitter
/// shifts the projection by (jx, jy) pixels, so a pixel sees the point (−jx, −jy) from its
/// centre.
fn jittered_expectation(
    size: u32,
    iterations: u32,
    radiance: impl Fn(f32, f32) -> f32,
) -> Vec<f32> {
    let halton = |mut i: u32, base: u32| {
        let (mut f, mut r) = (1.0f32, 0.0f32);
        while i > 0 {
            f /= base as f32;
            r += f * (i % base) as f32;
            i /= base;
        }
        r
    };
    let mut out = vec![0.0; (size * size) as usize];
    for it in 0..iterations {
        let (jx, jy) = (halton(it + 1, 2) - 0.5, halton(it + 1, 3) - 0.5);
        for j in 0..size {
            for i in 0..size {
                let x = -2.0 + (i as f32 + 0.5 - jx) * 4.0 / size as f32;
                let z = -2.0 + (j as f32 + 0.5 - jy) * 4.0 / size as f32;
                out[(j * size + i) as usize] += radiance(x, z) / iterations as f32;
            }
        }
    }
    out
}

/// Renders the plane lit by `light` with local illumination only, compares it with the
/// analytic radiance, then checks that photons carry the same direct light.
fn check_light(light: impl Bundle + Clone, radiance: impl Fn(f32, f32) -> f32, name: &str) {
    let (size, iterations) = (48u32, 8u32);
    let render = |settings: PhotonMapping| {
        let mut app = gpu_app();
        let (camera, _) = plane_scene(&mut app, light.clone(), size, settings);
        for _ in 0..200 {
            app.update();
            let done = app
                .world()
                .resource::<RppmRadiance>()
                .images
                .get(&camera)
                .is_some_and(|i| i.iteration >= iterations);
            if done {
                break;
            }
        }
        let image = app.world().resource::<RppmRadiance>().images[&camera].clone();
        assert_eq!(
            image.iteration, iterations,
            "{name}: the estimate did not reach {iterations} iterations"
        );
        RgbImage::from_rgba(image.width, image.height, &image.pixels)
    };
    let local = render(PhotonMapping {
        photons_per_iteration: PhotonCount::Fixed(0),
        max_iterations: Some(iterations),
        history: bevy_rppm::RppmHistory::Reset,
        ..default()
    });
    let expected = jittered_expectation(size, iterations, radiance);
    let mut worst = 0.0f32;
    for (got, want) in local.pixels.iter().zip(&expected) {
        let err = (got[1] - want).abs() / want.max(1e-3);
        worst = worst.max(if *want > 1e-3 {
            err
        } else {
            (got[1] - want).abs()
        });
    }
    let photons = render(PhotonMapping {
        photons_per_iteration: PhotonCount::Fixed(65_536),
        max_iterations: Some(iterations),
        debug_view: bevy_rppm::RppmDebugView::DirectPhotons,
        history: bevy_rppm::RppmHistory::Reset,
        ..default()
    });
    let energy = bevy_rppm_cli::image_io::energy_ratio(&photons, &local).unwrap();
    bevy_rppm_cli::image_io::write_exr(Path::new(&format!("/tmp/dbg_{name}_local.exr")), &local)
        .unwrap();
    bevy_rppm_cli::image_io::write_exr(
        Path::new(&format!("/tmp/dbg_{name}_photons.exr")),
        &photons,
    )
    .unwrap();
    eprintln!(
        "{name}: local vs analytic worst relative error {worst:.4}; photon/local energy {energy:.4}"
    );
    assert_eq!(bad_pixels(&local) + bad_pixels(&photons), 0);
    assert!(worst < 0.01, "{name}: local illumination off by {worst}");
    assert!(
        (0.97..1.03).contains(&energy),
        "{name}: photon energy ratio {energy}"
    );
}

/// The floor's mean radiance (the image's lower half) under a panel of `panel` standing
/// behind it, reflected by the floor's rough metal, after 16 iterations at 64².
fn panel_in_rough_metal(panel: StandardMaterial) -> f64 {
    let mut app = gpu_app();
    let world = app.world_mut();
    let mut materials = world.resource_mut::<Assets<StandardMaterial>>();
    let metal = materials.add(StandardMaterial {
        base_color: Color::WHITE,
        metallic: 1.0,
        perceptual_roughness: 0.3,
        ..default()
    });
    let panel = materials.add(panel);
    let indices = || Some(Indices::U32(vec![0, 1, 2, 0, 2, 3]));
    spawn_mesh(
        world,
        quad(5.0, indices(), true),
        metal,
        Transform::default(),
    );
    // Turned to face the camera (+Z), its lower edge on the floor.
    let upright = Transform::from_xyz(0.0, 0.8, -1.5)
        .with_rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2));
    spawn_mesh(world, quad(0.8, indices(), true), panel, upright);
    world.spawn(point_light_above(200.0, 4.0));
    let target = offscreen_target(&mut world.resource_mut::<Assets<Image>>(), 64, 64);
    let camera = world
        .spawn((
            Camera3d::default(),
            Transform::from_xyz(0.0, 0.6, 2.5).looking_at(Vec3::new(0.0, 0.2, -1.5), Vec3::Y),
            target,
            Msaa::Off,
            bevy::core_pipeline::tonemapping::Tonemapping::None,
            PhotonMapping {
                history: bevy_rppm::RppmHistory::Reset,
                ..default()
            },
            RppmReadback,
        ))
        .id();
    let image = estimate_after(&mut app, camera, 16, "panel in rough metal");
    region_mean(&image, 32..64, 0..64)
}

/// An unlit surface (`StandardMaterial::unlit`: seen in its base colour, lighting nothing)
/// shows in a rough metal floor as an emitter of that radiance does. Camera paths from a
/// rough vertex weigh the emission they meet by MIS against the shadow rays' draws on the
/// emitters, which never draw an unlit surface: it was weighed as an emitter, to nothing in
/// a scene without emitters (the floor 0.063 against the emitter's 0.258; 0.258 now).
#[test]
fn an_unlit_surface_shows_in_rough_metal_as_an_emitter_does() {
    let colour = LinearRgba::rgb(0.9, 0.6, 0.3);
    let unlit = panel_in_rough_metal(StandardMaterial {
        base_color: colour.into(),
        unlit: true,
        ..default()
    });
    let emitter = panel_in_rough_metal(StandardMaterial {
        base_color: Color::BLACK,
        emissive: colour,
        reflectance: 0.0,
        perceptual_roughness: 1.0,
        ..default()
    });
    println!("floor under the panel: unlit {unlit:.5}, emitter {emitter:.5}");
    assert!(
        (unlit / emitter - 1.0).abs() < 0.1,
        "unlit {unlit} against emitter {emitter}"
    );
}
