//! End-to-end tests on a real GPU adapter (Mesa's software Vulkan in CI): scene extraction,
//! accumulation resets, direct lighting against an analytic answer, and the CLI.
//!
//! Without an adapter these tests fail with the install hint; they never skip.

use std::path::{Path, PathBuf};
use std::process::Command;

use bevy::asset::RenderAssetUsages;
use bevy::camera::ScalingMode;
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use bevy_rppm::headless::{check_gpu_adapter, headless_app, offscreen_target};
use bevy_rppm::image_io::{RgbImage, bad_pixels, read_exr};
use bevy_rppm::{PhotonMapping, RppmRadiance, RppmReadback, RppmScene, RppmStats};

fn gpu_app() -> App {
    if let Err(hint) = check_gpu_adapter() {
        panic!("{hint}");
    }
    headless_app(Path::new(env!("CARGO_MANIFEST_DIR")))
}

fn frames(app: &mut App, n: usize) {
    for _ in 0..n {
        app.update();
    }
}

fn matte(materials: &mut Assets<StandardMaterial>, albedo: f32) -> Handle<StandardMaterial> {
    materials.add(StandardMaterial {
        base_color: Color::linear_rgb(albedo, albedo, albedo),
        perceptual_roughness: 1.0,
        metallic: 0.0,
        reflectance: 0.0,
        ..default()
    })
}

/// A square in the XZ plane, normal +Y, with the given index kind (or none).
fn quad(half: f32, indices: Option<Indices>, normals: bool) -> Mesh {
    let corners = [
        [-half, 0.0, -half],
        [-half, 0.0, half],
        [half, 0.0, half],
        [half, 0.0, -half],
    ];
    let order = [0usize, 1, 2, 0, 2, 3];
    let mut mesh = Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::default(),
    );
    if let Some(i) = indices {
        mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, corners.to_vec());
        if normals {
            mesh.insert_attribute(Mesh::ATTRIBUTE_NORMAL, vec![[0.0, 1.0, 0.0]; 4]);
        }
        mesh.insert_indices(i);
    } else {
        mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, order.map(|i| corners[i]).to_vec());
        if normals {
            mesh.insert_attribute(Mesh::ATTRIBUTE_NORMAL, vec![[0.0, 1.0, 0.0]; 6]);
        }
    }
    mesh
}

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
    let (m_cuboid, m_u16, m_plain) = {
        let mut meshes = world.resource_mut::<Assets<Mesh>>();
        (
            meshes.add(cuboid),
            meshes.add(quad(1.0, Some(Indices::U16(vec![0, 1, 2, 0, 2, 3])), true)),
            meshes.add(quad(2.0, None, false)),
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
        MeshMaterial3d(material),
        Transform::from_xyz(0.0, -5.0, 0.0),
    ));
    frames(&mut app, 3);
    let scene = app.world().resource::<RppmScene>().data.clone();
    assert_eq!(
        scene.triangles.len(),
        12 + 2 + 2,
        "cuboid 12, u16 quad 2, unindexed quad 2"
    );
    assert_eq!(scene.materials.len(), 1);
    // The cuboid's triangles, transformed on the CPU, must be in the table (order of entities
    // is not fixed, so look them up).
    let affine = transform.compute_affine();
    for tri in cuboid_indices.chunks(3) {
        let expected =
            [0, 1, 2].map(|k| affine.transform_point3(Vec3::from(cuboid_positions[tri[k]])));
        let found = scene.triangles.iter().any(|t| {
            t.positions()
                .iter()
                .zip(&expected)
                .all(|(a, b)| a.distance(*b) < 1e-5)
        });
        assert!(found, "transformed cuboid triangle {expected:?} missing");
    }
    // The quad without normals gets flat normals, pointing up for its winding.
    let flat: Vec<_> = scene
        .triangles
        .iter()
        .filter(|t| t.position_a[1] == -5.0)
        .collect();
    assert_eq!(flat.len(), 2);
    for t in flat {
        for n in [t.normal_a, t.normal_b, t.normal_c] {
            assert!(Vec3::from(n).distance(Vec3::Y) < 1e-6, "flat normal {n:?}");
        }
    }
}

/// A white plane, a point light above it and a camera looking straight down.
fn lit_plane(app: &mut App, light_lumens: f32, light_height: f32, size: u32) -> (Entity, Entity) {
    let light = (
        PointLight {
            intensity: light_lumens,
            range: 100.0,
            ..default()
        },
        Transform::from_xyz(0.0, light_height, 0.0),
    );
    plane_scene(app, light, size, PhotonMapping::default())
}

/// A 10 m white plane (albedo 0.8, no specular layer), `light`, and an orthographic camera
/// looking straight down at 4 m × 4 m of it.
fn plane_scene(
    app: &mut App,
    light: impl Bundle,
    size: u32,
    settings: PhotonMapping,
) -> (Entity, Entity) {
    let world = app.world_mut();
    world.spawn(light);
    let plane = world.resource_mut::<Assets<Mesh>>().add(quad(
        5.0,
        Some(Indices::U32(vec![0, 1, 2, 0, 2, 3])),
        true,
    ));
    let material = matte(&mut world.resource_mut::<Assets<StandardMaterial>>(), 0.8);
    let plane = world
        .spawn((
            Mesh3d(plane),
            MeshMaterial3d(material),
            Transform::default(),
        ))
        .id();
    let target = offscreen_target(&mut world.resource_mut::<Assets<Image>>(), size, size);
    let camera = world
        .spawn((
            Camera3d::default(),
            Projection::Orthographic(OrthographicProjection {
                scaling_mode: ScalingMode::Fixed {
                    width: 4.0,
                    height: 4.0,
                },
                ..OrthographicProjection::default_3d()
            }),
            Transform::from_xyz(0.0, 5.0, 0.0).looking_at(Vec3::ZERO, Vec3::NEG_Z),
            target,
            Msaa::Off,
            bevy::core_pipeline::tonemapping::Tonemapping::None,
            settings,
            RppmReadback,
        ))
        .id();
    (camera, plane)
}

fn iteration(app: &App, camera: Entity) -> u32 {
    app.world()
        .resource::<RppmStats>()
        .views
        .get(&camera)
        .map_or(0, |s| s.iteration)
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
        .get(&bevy_rppm::diagnostics::ITERATIONS)
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

fn rppm() -> Command {
    Command::new(env!("CARGO_BIN_EXE_rppm"))
}

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("rppm_test_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn assert_success(out: &std::process::Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn run_failing(cmd: &mut Command) -> String {
    let out = cmd.output().expect("run rppm");
    assert_eq!(out.status.code(), Some(2), "expected exit 2: {out:?}");
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(
        stderr
            .lines()
            .filter(|l| l.starts_with("rppm: error:"))
            .count(),
        1,
        "{stderr}"
    );
    stderr
}

#[test]
fn cli_reports_bad_input_in_one_line() {
    let missing = run_failing(rppm().args(["render", "/no/such/scene.gltf"]));
    assert!(
        missing.contains("cannot read /no/such/scene.gltf"),
        "{missing}"
    );
    let garbage = temp("garbage.gltf");
    std::fs::write(&garbage, "{ this is not gltf").unwrap();
    let unparsable = run_failing(
        rppm()
            .arg("render")
            .arg(&garbage)
            .args(["--iterations", "1"]),
    );
    assert!(unparsable.contains("cannot load"), "{unparsable}");
    let flag = run_failing(rppm().args(["render", "x.gltf", "--frobnicate"]));
    assert!(flag.contains("unknown option --frobnicate"), "{flag}");
    let zero = run_failing(rppm().args(["render", "x.gltf", "--iterations", "0"]));
    assert!(zero.contains("at least 1"), "{zero}");
    let ext = run_failing(rppm().args(["render", "x.gltf", "--out", "x.jpg"]));
    assert!(ext.contains(".exr or .png"), "{ext}");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/cornell_box.gltf");
    let no_gpu = run_failing(
        rppm()
            .arg("render")
            .arg(&scene)
            .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
            .env("VK_DRIVER_FILES", "/nonexistent/icd.json")
            .env("WGPU_BACKEND", "vulkan"),
    );
    assert!(no_gpu.contains("mesa-vulkan-drivers"), "{no_gpu}");
}

#[test]
fn cli_renders_a_scene_and_its_stats() {
    check_gpu_adapter().unwrap_or_else(|hint| panic!("{hint}"));
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/cornell_box.gltf");
    let (exr, png, stats) = (
        temp("cornell.exr"),
        temp("cornell.png"),
        temp("cornell.json"),
    );
    let out = rppm()
        .arg("render")
        .arg(&scene)
        .args(["--width", "48", "--height", "40", "--iterations", "3"])
        .arg("--out")
        .arg(&exr)
        .arg("--out")
        .arg(&png)
        .arg("--stats")
        .arg(&stats)
        .output()
        .unwrap();
    assert_success(&out);
    let image = read_exr(&exr).unwrap();
    assert_eq!((image.width, image.height), (48, 40));
    assert_eq!(bad_pixels(&image), 0);
    assert!(
        image.mean() > 0.01,
        "the Cornell box is lit, mean {}",
        image.mean()
    );
    assert!(std::fs::metadata(&png).unwrap().len() > 0);
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
    assert_eq!(json["iterations"], 3);
    assert_eq!(json["camera_from_scene"], true);
    for stage in ["shadow_maps", "gbuffer", "local_illumination"] {
        assert!(
            json["gpu_ms_last_frame"][stage].is_number(),
            "{stage} missing in {json}"
        );
    }
    assert!(json["memory_bytes"]["radiance"].as_u64().unwrap() >= 48 * 40 * 16);
}

#[test]
fn cli_uses_a_default_camera_when_the_scene_has_none() {
    check_gpu_adapter().unwrap_or_else(|hint| panic!("{hint}"));
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/cornell_box.gltf");
    let mut gltf: serde_json::Value =
        serde_json::from_slice(&std::fs::read(scene).unwrap()).unwrap();
    gltf.as_object_mut().unwrap().remove("cameras");
    for node in gltf["nodes"].as_array_mut().unwrap() {
        node.as_object_mut().unwrap().remove("camera");
    }
    let no_camera = temp("no_camera.gltf");
    std::fs::write(&no_camera, serde_json::to_vec(&gltf).unwrap()).unwrap();
    let (exr, stats) = (temp("no_camera.exr"), temp("no_camera.json"));
    let out = rppm()
        .arg("render")
        .arg(&no_camera)
        .args([
            "--width",
            "32",
            "--height",
            "32",
            "--iterations",
            "2",
            "--out",
        ])
        .arg(&exr)
        .arg("--stats")
        .arg(&stats)
        .output()
        .unwrap();
    assert_success(&out);
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
    assert_eq!(json["camera_from_scene"], false);
    let image = read_exr(&exr).unwrap();
    assert_eq!(bad_pixels(&image), 0);
    assert!(
        image.mean() > 0.01,
        "the default camera sees the lit box, mean {}",
        image.mean()
    );
}

fn render_debug(view: bevy_rppm::RppmDebugView) -> RgbImage {
    let settings = PhotonMapping {
        debug_view: view,
        ..default()
    };
    render_asset(settings, 64, 48, 2).image
}

#[test]
fn primary_rays_through_the_cubemap_match_the_gbuffer() {
    let raster = render_debug(bevy_rppm::RppmDebugView::GBufferNormals);
    let traced = render_debug(bevy_rppm::RppmDebugView::CubemapNormals);
    assert!(raster.mean() > 0.1, "the G-buffer image is empty");
    let differing = raster
        .pixels
        .iter()
        .zip(&traced.pixels)
        .filter(|(a, b)| a.iter().zip(b.iter()).any(|(x, y)| (x - y).abs() > 1e-3))
        .count();
    eprintln!(
        "cubemap vs G-buffer: {differing} of {} pixels differ",
        raster.pixels.len()
    );
    assert!(
        differing * 1000 <= raster.pixels.len(),
        "{differing} pixels differ"
    );
}

#[test]
fn cubemap_traversal_agrees_with_brute_force() {
    use bevy_rppm::cubemap::CubemapConfig;
    check_gpu_adapter().unwrap_or_else(|hint| panic!("{hint}"));
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/cornell_box.gltf");
    let defaults = PhotonMapping::default();
    let configs = vec![
        CubemapConfig {
            resolution: defaults.cubemap_resolution,
            tile_size: 1,
            bins: defaults.bins,
        },
        CubemapConfig {
            resolution: 64,
            tile_size: 4,
            bins: 1,
        },
    ];
    let (rows, _) = bevy_rppm::headless::bench_dirt(&scene, configs, 8192, 8192).unwrap();
    assert_eq!(rows.len(), 2);
    for row in rows {
        eprintln!("{row:?}");
        assert!(row.agreement >= 0.999, "{row:?}");
        assert_eq!(row.false_hits, 0, "{row:?}");
    }
}

/// The reference box-filtered down by an integer factor (pixel averages stay pixel averages).
fn downsample(image: &RgbImage, factor: usize) -> RgbImage {
    let (w, h) = (image.width / factor, image.height / factor);
    let mut pixels = vec![[0.0f32; 3]; w * h];
    for y in 0..h * factor {
        for x in 0..w * factor {
            let p = image.at(x, y);
            let out = &mut pixels[(y / factor) * w + x / factor];
            for c in 0..3 {
                out[c] += p[c] / (factor * factor) as f32;
            }
        }
    }
    RgbImage {
        width: w,
        height: h,
        pixels,
    }
}

#[test]
fn photon_mapping_converges_towards_the_reference() {
    use bevy_rppm::image_io::{energy_ratio, relmse};
    let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
    let reference = downsample(&read_exr(&assets.join("cornell_box.ref.exr")).unwrap(), 4);
    let settings = PhotonMapping {
        photons_per_iteration: 8192,
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

/// The shipped Cornell box rendered in-process through the CLI's code path.
fn render_asset(
    settings: PhotonMapping,
    width: u32,
    height: u32,
    iterations: u32,
) -> bevy_rppm::headless::RenderResult {
    use bevy_rppm::headless::{Budget, RenderRequest, render_gltf};
    let request = RenderRequest {
        scene: Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/cornell_box.gltf"),
        width,
        height,
        budget: Budget::Iterations(iterations),
        settings,
    };
    render_gltf(&request, |_| {}).unwrap_or_else(|e| panic!("{e}"))
}

fn render_box(settings: PhotonMapping, size: u32, iterations: u32) -> RgbImage {
    render_asset(settings, size, size, iterations).image
}

fn region_mean(
    image: &RgbImage,
    rows: std::ops::Range<usize>,
    cols: std::ops::Range<usize>,
) -> f64 {
    let mut sum = 0.0;
    let mut n = 0;
    for y in rows {
        for x in cols.clone() {
            sum += image.at(x, y).iter().map(|&v| v as f64).sum::<f64>();
            n += 3;
        }
    }
    sum / n as f64
}

#[test]
fn photons_carry_the_same_direct_light_as_the_local_stage() {
    use bevy_rppm::image_io::energy_ratio;
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
fn error_falls_faster_than_the_square_root_of_iterations() {
    use bevy_rppm::image_io::relmse;
    let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
    let reference = downsample(&read_exr(&assets.join("cornell_box.ref.exr")).unwrap(), 4);
    // Few photons and a small radius: the variance term dominates, as it does in the long run
    // (the shipped reference also differs by Bevy's 4% specular layer, a floor near 0.003).
    let settings = PhotonMapping {
        photons_per_iteration: 1024,
        initial_radius_pixels: 2.0,
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

#[derive(Resource, Default)]
struct TargetPixels(Option<Vec<u8>>);

/// Reads the camera's target image back every frame into `TargetPixels`.
fn read_back_view(world: &mut World, image: Handle<Image>) {
    use bevy::render::gpu_readback::{Readback, ReadbackComplete};
    world.init_resource::<TargetPixels>();
    world.spawn(Readback::texture(image)).observe(
        |event: On<ReadbackComplete>, mut pixels: ResMut<TargetPixels>| {
            pixels.0 = Some(event.data.clone())
        },
    );
}

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
        let expected = bevy_rppm::image_io::tonemap_srgb8([p[0], p[1], p[2]]);
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
        photons_per_iteration: 0,
        max_iterations: Some(iterations),
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
        photons_per_iteration: 65_536,
        max_iterations: Some(iterations),
        debug_view: bevy_rppm::RppmDebugView::DirectPhotons,
        ..default()
    });
    let energy = bevy_rppm::image_io::energy_ratio(&photons, &local).unwrap();
    bevy_rppm::image_io::write_exr(Path::new(&format!("/tmp/dbg_{name}_local.exr")), &local)
        .unwrap();
    bevy_rppm::image_io::write_exr(Path::new(&format!("/tmp/dbg_{name}_photons.exr")), &photons)
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
        scene.triangles.len(),
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

fn srgb_to_linear(v: u8) -> f32 {
    let c = v as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Runs frames until the camera's target has been read back at least once more.
fn capture_view(app: &mut App) -> Vec<u8> {
    app.world_mut().resource_mut::<TargetPixels>().0 = None;
    for _ in 0..50 {
        app.update();
        if let Some(pixels) = app.world().resource::<TargetPixels>().0.clone() {
            return pixels;
        }
    }
    panic!("the view was never read back");
}

#[test]
fn indirect_mode_adds_our_light_to_bevys_and_off_gives_bevys_image() {
    check_gpu_adapter().unwrap_or_else(|hint| panic!("{hint}"));
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/cornell_box.gltf");
    let mut app = bevy_rppm::headless::load_gltf(&scene).unwrap();
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
            photons_per_iteration: 16_384,
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

/// The example binary `name`, built next to this test binary by `cargo test`.
fn example_binary(name: &str) -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    exe.parent()
        .unwrap()
        .parent()
        .unwrap()
        .join("examples")
        .join(name)
}

#[test]
fn examples_run_headless_and_save_their_view() {
    check_gpu_adapter().unwrap_or_else(|hint| panic!("{hint}"));
    for (name, frames) in [
        ("toggle", "12"),
        ("cornell", "12"),
        ("bunny", "12"),
        ("pool", "3"),
    ] {
        let out = temp(&format!("example_{name}.png"));
        let run = Command::new(example_binary(name))
            .args(["--headless", "--frames", frames, "--out"])
            .arg(&out)
            .output()
            .unwrap_or_else(|e| panic!("cannot run the {name} example: {e}"));
        assert!(
            run.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&run.stderr)
        );
        let decoder =
            png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&out).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut pixels = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut pixels).unwrap();
        let lit = pixels[..info.buffer_size()]
            .iter()
            .filter(|&&v| v > 16)
            .count();
        eprintln!(
            "{name}: {}x{}, {lit} lit channel values",
            info.width, info.height
        );
        assert!(
            lit > pixels.len() / 10,
            "{name}: the saved view is nearly black"
        );
    }
}

/// Runs frames until the camera has accumulated `n` iterations (at most 100 frames).
fn until_iterations(app: &mut App, camera: Entity, n: u32) {
    for _ in 0..100 {
        if iteration(app, camera) >= n {
            return;
        }
        app.update();
    }
    panic!("fewer than {n} iterations after 100 frames");
}

fn radiance(app: &App, camera: Entity) -> bevy_rppm::RadianceImage {
    app.world().resource::<RppmRadiance>().images[&camera].clone()
}

fn assert_finite(image: &bevy_rppm::RadianceImage, what: &str) {
    let bad = image
        .pixels
        .iter()
        .filter(|p| p[..3].iter().any(|v| !v.is_finite() || *v < 0.0))
        .count();
    assert_eq!(bad, 0, "{what}: {bad} pixels are NaN, infinite or negative");
}

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
            let expected = bevy_rppm::radius2_after(16.0, stats.iteration, alpha).sqrt();
            eprintln!(
                "α {alpha}: iteration {}, radius {radius:.3e} px",
                stats.iteration
            );
            assert!(radius.is_finite() && radius > 0.0 && radius <= 4.0);
            assert!(
                (radius / expected - 1.0).abs() < 1e-9,
                "{radius} vs {expected}"
            );
            assert_finite(&radiance(&app, camera), &format!("α {alpha} at {target}"));
        }
    }
}

/// Every knob at both ends of its range, on the shipped Cornell box: finite, no error.
#[test]
fn extreme_settings_render_finite_images() {
    let base = PhotonMapping {
        photons_per_iteration: 4096,
        ..default()
    };
    let cases: Vec<(&str, PhotonMapping)> = vec![
        (
            "0 photons",
            PhotonMapping {
                photons_per_iteration: 0,
                ..base.clone()
            },
        ),
        (
            "1 photon",
            PhotonMapping {
                photons_per_iteration: 1,
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
                initial_radius_pixels: 0.25,
                ..base.clone()
            },
        ),
        (
            "radius 256 px",
            PhotonMapping {
                initial_radius_pixels: 256.0,
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

/// Renders the shipped Cornell box with its root scaled by `scale` and its lights' power
/// multiplied by `power`.
fn render_transformed_box(scale: f32, power: f32, size: u32) -> RgbImage {
    use bevy::world_serialization::WorldAssetRoot;
    use bevy_rppm::headless::{Budget, RenderRequest, load_gltf, render_loaded};
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/cornell_box.gltf");
    let mut app = load_gltf(&scene).unwrap_or_else(|e| panic!("{e}"));
    let world = app.world_mut();
    let mut roots = world.query_filtered::<&mut Transform, With<WorldAssetRoot>>();
    for mut t in roots.iter_mut(world) {
        t.scale = Vec3::splat(scale);
    }
    let mut lights = world.query::<&mut PointLight>();
    for mut light in lights.iter_mut(world) {
        light.intensity *= power;
        light.range *= scale;
    }
    let request = RenderRequest {
        scene,
        width: size,
        height: size,
        budget: Budget::Iterations(16),
        settings: PhotonMapping {
            photons_per_iteration: 16_384,
            ..default()
        },
    };
    render_loaded(&mut app, &request, |_| {})
        .unwrap_or_else(|e| panic!("{e}"))
        .image
}

fn scaled(image: &RgbImage, k: f32) -> RgbImage {
    RgbImage {
        pixels: image.pixels.iter().map(|p| p.map(|v| v * k)).collect(),
        ..image.clone()
    }
}

/// Radiance is invariant under scaling the scene when a point light's intensity (W/sr)
/// scales with the area (E ∝ I/d²), and linear in the light's power.
#[test]
fn scene_scale_and_light_power_extremes_match_the_reference() {
    use bevy_rppm::image_io::relmse;
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
    let cube = world
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::new(1.0, 1.0, 1.0));
    world.spawn((
        Mesh3d(cube),
        MeshMaterial3d(material),
        Transform::from_xyz(0.0, 0.6, 0.0),
    ));
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

/// Passes and shader paths follow the scene and settings: a matte plane compiles no
/// specular path, depth 1 runs no photon pass, eye depth 1 no importons; glass adds
/// refraction.
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
            let world = app.world_mut();
            let material = world
                .resource_mut::<Assets<StandardMaterial>>()
                .add(StandardMaterial {
                    specular_transmission: 1.0,
                    perceptual_roughness: 0.0,
                    ..default()
                });
            let ball = world.resource_mut::<Assets<Mesh>>().add(Sphere::new(0.4));
            world.spawn((
                Mesh3d(ball),
                MeshMaterial3d(material),
                Transform::from_xyz(0.0, 0.5, 0.0),
            ));
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
    // Matte albedo 0.8: the store holds Σ 0.8ʲ ≈ 4 photons per emitted one, not 7.
    let store = memory["photons"] as f64 / (262_144.0 * 64.0);
    assert!(
        store < 5.0,
        "photon store holds {store:.2} photons per emitted photon"
    );
    let (one_bounce, _, memory) = passes(
        PhotonMapping {
            max_photon_depth: 1,
            ..default()
        },
        false,
    );
    assert!(
        !one_bounce.contains(&"photon_trace".to_string()),
        "{one_bounce:?}"
    );
    assert!(!memory.contains_key("photons"));
    let (glass, paths, _) = passes(PhotonMapping::default(), true);
    assert!(paths.contains(&"REFRACTION".to_string()), "{paths:?}");
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

/// Without `RppmReadback` (every game) the deep cubemap's lists still grow until nothing
/// overflows: their counters come back without a stall.
#[test]
fn cubemap_lists_grow_without_a_blocking_read_back() {
    let mut app = gpu_app();
    let (camera, _) = lit_plane(&mut app, 1000.0, 2.0, 32);
    app.world_mut().entity_mut(camera).remove::<RppmReadback>();
    let mut seen = Vec::new();
    for _ in 0..60 {
        app.update();
        let Some(stats) = app.world().resource::<RppmStats>().views.get(&camera) else {
            continue;
        };
        seen.push((stats.cubemap_nodes, stats.cubemap_overflow));
        if stats.cubemap_nodes > 0 && stats.cubemap_overflow == 0 && seen.iter().any(|s| s.1 > 0) {
            eprintln!("cubemap (nodes, overflow) per frame: {seen:?}");
            return;
        }
    }
    panic!("the lists never grew to hold every entry: {seen:?}");
}
