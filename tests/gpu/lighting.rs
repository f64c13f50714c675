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
            photons_per_iteration: 0,
            ..default()
        },
        64,
        4,
    );
    // A one-pixel gather radius: wide discs blur across box edges and shadow borders, which
    // is the estimator's bias, not a flux error.
    let photons = render_box(
        PhotonMapping {
            photons_per_iteration: 65_536,
            initial_radius_pixels: 1.0,
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
