//! Helpers every test module shares, and the imports they all use.

pub use std::path::{Path, PathBuf};
pub use std::process::Command;

pub use bevy::asset::RenderAssetUsages;
pub use bevy::camera::ScalingMode;
pub use bevy::mesh::{Indices, PrimitiveTopology};
pub use bevy::prelude::*;
pub use bevy_rppm::{
    InitialRadius, PhotonCount, PhotonMapping, RppmRadiance, RppmReadback, RppmScene, RppmStats,
};
pub use bevy_rppm_cli::headless::{check_gpu_adapter, headless_app, offscreen_target};
pub use bevy_rppm_cli::image_io::{RgbImage, bad_pixels, read_exr};

pub fn gpu_app() -> App {
    if let Err(hint) = check_gpu_adapter() {
        panic!("{hint}");
    }
    headless_app(Path::new(env!("CARGO_MANIFEST_DIR")))
}

pub fn frames(app: &mut App, n: usize) {
    for _ in 0..n {
        app.update();
    }
}

pub fn matte(materials: &mut Assets<StandardMaterial>, albedo: f32) -> Handle<StandardMaterial> {
    materials.add(StandardMaterial {
        base_color: Color::linear_rgb(albedo, albedo, albedo),
        perceptual_roughness: 1.0,
        metallic: 0.0,
        reflectance: 0.0,
        ..default()
    })
}

/// A square in the XZ plane, normal +Y, with the given index kind (or none).
pub fn quad(half: f32, indices: Option<Indices>, normals: bool) -> Mesh {
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

/// A white plane, a point light above it and a camera looking straight down; any change
/// starts the estimate again (`RppmHistory::Reset`).
pub fn lit_plane(
    app: &mut App,
    light_lumens: f32,
    light_height: f32,
    size: u32,
) -> (Entity, Entity) {
    let light = point_light_above(light_lumens, light_height);
    let settings = PhotonMapping {
        history: bevy_rppm::RppmHistory::Reset,
        ..default()
    };
    plane_scene(app, light, size, settings)
}

/// A point light of `lumens` at `height` above the origin (range 100 m).
pub fn point_light_above(lumens: f32, height: f32) -> (PointLight, Transform) {
    (
        PointLight {
            intensity: lumens,
            range: 100.0,
            ..default()
        },
        Transform::from_xyz(0.0, height, 0.0),
    )
}

/// A 10 m white plane (albedo 0.8, no specular layer), `light`, and an orthographic camera
/// looking straight down at 4 m × 4 m of it.
pub fn plane_scene(
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

pub fn iteration(app: &App, camera: Entity) -> u32 {
    app.world()
        .resource::<RppmStats>()
        .views
        .get(&camera)
        .map_or(0, |s| s.iteration)
}

/// `target/<profile>`, where cargo puts the binaries this test binary runs.
fn target_dir() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    exe.parent().unwrap().parent().unwrap().to_path_buf()
}

/// The `rppm` binary of the tool crate. `cargo test --workspace` builds it before any test
/// runs (the tool crate has integration tests of its own).
pub fn rppm() -> Command {
    Command::new(rppm_path())
}

pub fn rppm_path() -> PathBuf {
    let path = target_dir().join(format!("rppm{}", std::env::consts::EXE_SUFFIX));
    assert!(
        path.exists(),
        "{} is missing: run the tests with `cargo test --workspace`",
        path.display()
    );
    path
}

/// A fresh path for a test's output (what an earlier run left there is removed, so it cannot
/// pass for this run's), in one folder beside the test binary that each run reuses (a folder
/// per process in the system's temp folder piled up, one per run).
pub fn temp(name: &str) -> PathBuf {
    let dir = target_dir().join("rppm_test_output");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    if path.is_dir() {
        std::fs::remove_dir_all(&path).unwrap();
    } else if path.exists() {
        std::fs::remove_file(&path).unwrap();
    }
    path
}

pub fn assert_success(out: &std::process::Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

pub fn run_failing(cmd: &mut Command) -> String {
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

pub fn render_debug(view: bevy_rppm::RppmDebugView) -> RgbImage {
    let settings = PhotonMapping {
        debug_view: view,
        ..default()
    };
    render_asset(settings, 64, 48, 2).image
}

/// `scene` (a path) at `width` × `height` after `iterations` of 65 536 photons from `seed`.
pub fn render_fixed(scene: &Path, width: u32, height: u32, iterations: u32, seed: u32) -> RgbImage {
    use bevy_rppm_cli::headless::{Budget, RenderRequest, render_gltf};
    let request = RenderRequest {
        scene: scene.to_path_buf(),
        width,
        height,
        budget: Budget::Iterations(iterations),
        settings: PhotonMapping {
            photons_per_iteration: PhotonCount::Fixed(65_536),
            seed,
            ..default()
        },
    };
    render_gltf(&request, |_| {})
        .unwrap_or_else(|e| panic!("{}: {e}", scene.display()))
        .image
}

/// `scene` (a path) at 128² after 30 iterations of 65 536 photons from `seed`: the tests that
/// compare seeds, where one seed's rare sample is what they look for.
pub fn render_seed(scene: &Path, seed: u32) -> RgbImage {
    render_fixed(scene, 128, 128, 30, seed)
}

/// The reference box-filtered down by an integer factor (pixel averages stay pixel averages).
pub fn downsample(image: &RgbImage, factor: usize) -> RgbImage {
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

/// The shipped Cornell box rendered in-process through the CLI's code path.
pub fn render_asset(
    settings: PhotonMapping,
    width: u32,
    height: u32,
    iterations: u32,
) -> bevy_rppm_cli::headless::RenderResult {
    use bevy_rppm_cli::headless::{Budget, RenderRequest, render_gltf};
    let request = RenderRequest {
        scene: Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/cornell_box.gltf"),
        width,
        height,
        budget: Budget::Iterations(iterations),
        settings,
    };
    render_gltf(&request, |_| {}).unwrap_or_else(|e| panic!("{e}"))
}

/// A glTF scene rendered at 64², 16 iterations, against its reference averaged down to 64²
/// (`against_reference`).
pub fn against_reference_64(name: &str, scene: PathBuf, reference: &Path) -> (f64, f64) {
    against_reference(name, scene, reference, 64, 16)
}

/// A glTF scene rendered in-process at `size`², `iterations` of 65 536 photons, every pixel
/// finite, against its reference averaged down to that size: (relMSE, energy ratio), printed
/// under `name`.
pub fn against_reference(
    name: &str,
    scene: PathBuf,
    reference: &Path,
    size: u32,
    iterations: u32,
) -> (f64, f64) {
    let image = render_fixed(&scene, size, size, iterations, 0);
    assert_eq!(bad_pixels(&image), 0, "{}", scene.display());
    let reference = read_exr(reference).unwrap();
    let reference = downsample(&reference, reference.width / size as usize);
    let error = bevy_rppm_cli::image_io::relmse(&image, &reference).unwrap();
    let energy = bevy_rppm_cli::image_io::energy_ratio(&image, &reference).unwrap();
    println!(
        "{name}: relMSE {error:.4}, energy {energy:.4} after {iterations} iterations at {size}²"
    );
    (error, energy)
}

/// A glTF scene rendered in-process at 64², `iterations` of 65 536 photons, every pixel finite.
pub fn render_gltf_64(scene: PathBuf, iterations: u32) -> RgbImage {
    let image = render_fixed(&scene, 64, 64, iterations, 0);
    assert_eq!(bad_pixels(&image), 0, "{}", scene.display());
    image
}

pub fn render_box(settings: PhotonMapping, size: u32, iterations: u32) -> RgbImage {
    render_asset(settings, size, size, iterations).image
}

pub fn region_mean(
    image: &RgbImage,
    rows: std::ops::Range<usize>,
    cols: std::ops::Range<usize>,
) -> f64 {
    (0..3)
        .map(|c| region_channel_mean(image, rows.clone(), cols.clone(), c))
        .sum::<f64>()
        / 3.0
}

/// The mean of one colour channel over a block of pixels.
pub fn region_channel_mean(
    image: &RgbImage,
    rows: std::ops::Range<usize>,
    cols: std::ops::Range<usize>,
    channel: usize,
) -> f64 {
    let mut sum = 0.0;
    for y in rows.clone() {
        for x in cols.clone() {
            sum += image.at(x, y)[channel] as f64;
        }
    }
    sum / (rows.len() * cols.len()) as f64
}

#[derive(Resource, Default)]
pub struct TargetPixels(pub Option<Vec<u8>>);

/// Reads the camera's target image back every frame into `TargetPixels`.
pub fn read_back_view(world: &mut World, image: Handle<Image>) {
    use bevy::render::gpu_readback::{Readback, ReadbackComplete};
    world.init_resource::<TargetPixels>();
    world.spawn(Readback::texture(image)).observe(
        |event: On<ReadbackComplete>, mut pixels: ResMut<TargetPixels>| {
            pixels.0 = Some(event.data.clone())
        },
    );
}

pub fn srgb_to_linear(v: u8) -> f32 {
    let c = v as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Runs frames until the camera's target has been read back at least once more.
pub fn capture_view(app: &mut App) -> Vec<u8> {
    app.world_mut().resource_mut::<TargetPixels>().0 = None;
    for _ in 0..50 {
        app.update();
        if let Some(pixels) = app.world().resource::<TargetPixels>().0.clone() {
            return pixels;
        }
    }
    panic!("the view was never read back");
}

/// The example binary `name`, built next to this test binary by `cargo test`.
pub fn example_binary(name: &str) -> PathBuf {
    target_dir().join("examples").join(name)
}

/// Runs frames until the camera has accumulated `n` iterations (at most 100 frames).
pub fn until_iterations(app: &mut App, camera: Entity, n: u32) {
    for _ in 0..100 {
        if iteration(app, camera) >= n {
            return;
        }
        app.update();
    }
    panic!("fewer than {n} iterations after 100 frames");
}

pub fn radiance(app: &App, camera: Entity) -> bevy_rppm::RadianceImage {
    app.world().resource::<RppmRadiance>().images[&camera].clone()
}

pub fn assert_finite(image: &bevy_rppm::RadianceImage, what: &str) {
    let bad = image
        .pixels
        .iter()
        .filter(|p| p[..3].iter().any(|v| !v.is_finite() || *v < 0.0))
        .count();
    assert_eq!(bad, 0, "{what}: {bad} pixels are NaN, infinite or negative");
}

/// Renders the shipped Cornell box with its root scaled by `scale` and its lights' power
/// multiplied by `power`.
pub fn render_transformed_box(scale: f32, power: f32, size: u32) -> RgbImage {
    use bevy::world_serialization::WorldAssetRoot;
    use bevy_rppm_cli::headless::{Budget, RenderRequest, render_loaded};
    use bevy_rppm_cli::load::load_gltf;
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
            photons_per_iteration: PhotonCount::Fixed(16_384),
            ..default()
        },
    };
    render_loaded(&mut app, &request, |_| {})
        .unwrap_or_else(|e| panic!("{e}"))
        .image
}

pub fn scaled(image: &RgbImage, k: f32) -> RgbImage {
    RgbImage {
        pixels: image.pixels.iter().map(|p| p.map(|v| v * k)).collect(),
        ..image.clone()
    }
}

/// A horizontal square of half-size `half` at height `y`, facing up (an occluder between
/// `plane_scene`'s light and plane).
pub fn spawn_occluder(app: &mut App, half: f32, y: f32, material: StandardMaterial) -> Entity {
    let world = app.world_mut();
    let mesh = quad(half, Some(Indices::U32(vec![0, 1, 2, 0, 2, 3])), true);
    let material = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(material);
    spawn_mesh(world, mesh, material, Transform::from_xyz(0.0, y, 0.0))
}

/// A smooth glass ball of radius 0.4 m, 0.5 m above the origin.
pub fn spawn_glass_ball(world: &mut World) {
    let glass = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial {
            specular_transmission: 1.0,
            perceptual_roughness: 0.0,
            ..default()
        });
    let ball = world.resource_mut::<Assets<Mesh>>().add(Sphere::new(0.4));
    world.spawn((
        Mesh3d(ball),
        MeshMaterial3d(glass),
        Transform::from_xyz(0.0, 0.5, 0.0),
    ));
}

/// `mesh` with `material` at `transform`.
pub fn spawn_mesh(
    world: &mut World,
    mesh: impl Into<Mesh>,
    material: Handle<StandardMaterial>,
    transform: Transform,
) -> Entity {
    let mesh = world.resource_mut::<Assets<Mesh>>().add(mesh.into());
    world
        .spawn((Mesh3d(mesh), MeshMaterial3d(material), transform))
        .id()
}

/// The camera's estimate after `n` iterations, checked finite.
pub fn estimate_after(app: &mut App, camera: Entity, n: u32, what: &str) -> RgbImage {
    until_iterations(app, camera, n);
    let image = radiance(app, camera);
    assert_finite(&image, what);
    RgbImage::from_rgba(image.width, image.height, &image.pixels)
}
