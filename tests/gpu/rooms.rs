//! Rooms kept in `assets/suite/random/` with their references, each the scene where a fault
//! was found (`tools/random_scenes.py`, `tools/suite_scenes.py --tests`).

use std::ops::RangeInclusive;
use std::path::Path;

use super::util::*;

/// A room of `tools/random_scenes.py --wide` (seed 4, room 4: an open room under a sky, an
/// emissive box of 1 m, two panels, a sphere light, a glossy floor) against its reference,
/// 64², 16 iterations. A pixel's first draws came from Roberts' R₈, whose consecutive draws
/// move nearly in step over the first iterations: the emitter's point, drawn after the sky's
/// direction, fell on such a pair, and the walls were covered in noise (relMSE 0.049). In
/// Owen-scrambled Sobol pairs (`sequence_draw`): 0.032; with the emitter drawn by solid angle
/// (below): 0.026; with the cosine ray (`EMITTER_RAYS`) besides: 0.025.
#[test]
fn a_room_under_a_sky_and_an_emissive_box_has_quiet_walls() {
    room_within("r4_04", 64, 16, 0.044, 0.97..=1.03);
}

/// A glowing box 5 mm over the floor (room 1 of `random_scenes.py --seed 6 --wide`, with a
/// window, the sun and the sky): the floor beside it sees its faces up close, where a point
/// drawn by area weighs 1/d² and a few such samples speckle the floor's contact. Drawn by the
/// solid angle it subtends (`spherical_triangle`), the weight stays bounded: 0.0108 by area,
/// 0.0061 by solid angle, 0.0054 with the cosine ray (`EMITTER_RAYS`) besides.
#[test]
fn the_floor_beside_a_glowing_box_has_no_speckle() {
    room_within("r6_01", 64, 16, 0.0085, 0.97..=1.03);
}

/// A glowing ball of 2 300 triangles resting on a checkered plastic floor (room 5 of
/// `random_scenes.py --count 6 --seed 11 --wide --textured`, its dense metal sphere taken out
/// by `variant.py drop`). From the floor beside it the ball fills half the sky, but the
/// emitter sample draws it a triangle at a time by power: the nearest triangles, drawn once in
/// thousands of tries, were worth thousands of times their light, fireflies (`rppm render` at
/// 64², 16 iterations: relMSE 0.037–0.066 by seed). A ray drawn by cosine finds the ball as
/// well (`EMITTER_RAYS`, MIS): 0.021 by every seed; 0.018 here.
#[test]
fn the_floor_beside_a_glowing_ball_has_no_fireflies() {
    room_within("glowing_ball", 64, 16, 0.028, 0.97..=1.03);
}

/// Walls of small repeated bumps (normal maps) in an open room under a sky, the sun, a
/// sphere light and a panel (room 3 of `random_scenes.py --seed 8 --textured`). Two ways they
/// came out bright (128², 64 iterations: energy 1.041, relMSE 0.0092): the G-buffer read the
/// normal map's mip at the pixel's footprint, whose averaged normals are flatter than the
/// texels they average; and light from behind a wall's own triangle (the sun) lit the bumps
/// turned toward it. Now 1.007 and 0.0057 (here, 64² and 16 iterations: 0.9875).
#[test]
fn walls_of_small_bumps_are_not_brighter_than_their_texels() {
    room_within("r8_03", 64, 16, 0.03, 0.96..=1.025);
}

/// A glass ball (tinted, smooth) under two sphere lights (room 8 of `random_scenes.py --seed
/// 10 --textured`): the bulbs' highlights on the ball are their Fresnel reflections, which a
/// camera path took in one try of 25, each worth 25 times the highlight, and the outlier
/// spread smeared them into blobs (128², 64 iterations: relMSE 0.040). The peek along smooth
/// glass's reflection (`REFLECTED_EMISSION`) now sees the sphere lights too. At 128² (the
/// highlights are 2 pixels wide), 24 iterations: 0.0170 before, 0.0055 now.
#[test]
fn a_bulbs_highlight_on_a_glass_ball_stays_sharp() {
    room_within("r10_08", 128, 24, 0.011, 0.97..=1.03);
}

/// A clear ball (ior 1.4) on the floor of a closed room under two sphere lights (room 1 of
/// `random_scenes.py --count 6 --seed 48 --wide`): looking through it, the camera sees the
/// caustic it focuses beneath itself, magnified. Its importons gathered over discs as wide as
/// the path's length makes a pixel, several times what the lens lets a pixel see, and the
/// caustic's sharp ellipse came out a smooth band (128², 24 iterations: relMSE 0.0088 at
/// 30 s). The pixel's footprint is now carried through the glass by ray differentials
/// (`shaders/importons/footprint.wgsl`): 0.0055 here (seeds 0–2: 0.0054–0.0058), 0.0087 before.
#[test]
fn a_caustic_seen_through_a_glass_ball_stays_sharp() {
    room_within("r48_01", 128, 24, 0.0072, 0.97..=1.03);
}

/// A room open under a sky with a mirror, two clear balls and three lights (room 5 of
/// `random_scenes.py --count 6 --seed 48 --wide`): the caustic the front ball focuses on the
/// floor has a sharp rim, which the global gather radius (2.4 pixels after 24 iterations)
/// smears; the rim held 80 % of the error. Each pixel's kernel now shrinks where its bias
/// outweighs its noise (`PhotonMapping::adaptive_kernel`, `shaders/splat/splat.wgsl`): at
/// 128², 24 iterations of 131 072 photons, seeds 0–2, relMSE 0.0104–0.0111 against
/// 0.0136–0.0146 with the global radius (0.75–0.80×).
#[test]
fn a_caustics_rim_stays_sharp_where_its_kernels_shrink() {
    let room = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/suite/random");
    let reference = read_exr(&room.join("r48_05.ref.exr")).unwrap();
    let error = |adaptive_kernel| {
        let image = render_kernels(&room.join("r48_05.gltf"), 24, 131_072, adaptive_kernel);
        bevy_rppm_cli::image_io::relmse(&image, &reference).unwrap()
    };
    let (adaptive, global) = (error(true), error(false));
    println!("r48_05: relMSE {adaptive:.4} with adaptive kernels, {global:.4} without");
    assert!(
        adaptive < 0.0125 && adaptive < 0.88 * global,
        "relMSE {adaptive:.4} adaptive, {global:.4} global"
    );
}

/// `mirror_caustic`'s glass ball, seen from behind its caustic, shows the caustic's bright
/// rim through its foot: the camera's importons gather it on the floor over discs as wide as
/// the path through the ball makes a pixel. They now shrink where they blur as the direct
/// splat's kernels do (`ADAPTIVE_KERNEL` in `shaders/indirect_splat/indirect_splat.wgsl`,
/// the importon's own statistics): at 128², 32 iterations of 65 536 photons, the ball's foot
/// (rows 60–75, columns 104–127) reads relMSE 0.010 against 0.051 with the global radius
/// (the code before: 0.051 either way), the image 0.0014 against 0.0024.
#[test]
fn a_caustic_seen_through_glass_stays_sharp_where_importon_kernels_shrink() {
    let suite = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/suite");
    let reference = read_exr(&suite.join("mirror_caustic.ref.exr")).unwrap();
    let reference = downsample(&reference, reference.width / 128);
    let foot = |image: &RgbImage| {
        let (rows, cols) = (60..76, 104..128);
        let crop = |i: &RgbImage| RgbImage {
            width: cols.len(),
            height: rows.len(),
            pixels: (rows.clone())
                .flat_map(|y| cols.clone().map(move |x| (x, y)))
                .map(|(x, y)| i.at(x, y))
                .collect(),
        };
        bevy_rppm_cli::image_io::relmse(&crop(image), &crop(&reference)).unwrap()
    };
    let errors = |adaptive_kernel| {
        let image = render_kernels(
            &suite.join("mirror_caustic.gltf"),
            32,
            65_536,
            adaptive_kernel,
        );
        let whole = bevy_rppm_cli::image_io::relmse(&image, &reference).unwrap();
        (foot(&image), whole)
    };
    let (adaptive, global) = (errors(true), errors(false));
    println!("mirror_caustic: the ball's foot {adaptive:.4?} adaptive, {global:.4?} global");
    assert!(
        adaptive.0 < 0.5 * global.0 && adaptive.1 < global.1,
        "the ball's foot and the image: {adaptive:.4?} adaptive, {global:.4?} global"
    );
}

/// `scene` at 128², `iterations` of `photons`, with or without adaptive kernels; every pixel
/// finite.
fn render_kernels(scene: &Path, iterations: u32, photons: u32, adaptive_kernel: bool) -> RgbImage {
    use bevy_rppm_cli::headless::{Budget, RenderRequest, render_gltf};
    let request = RenderRequest {
        scene: scene.to_path_buf(),
        width: 128,
        height: 128,
        budget: Budget::Iterations(iterations),
        settings: PhotonMapping {
            photons_per_iteration: PhotonCount::Fixed(photons),
            adaptive_kernel,
            ..default()
        },
    };
    let image = render_gltf(&request, |_| {}).unwrap().image;
    assert_eq!(bad_pixels(&image), 0);
    image
}

/// A room kept in `assets/suite/random/` against its reference, at 64² and 16 iterations.
/// A glowing ball on the floor with a clear pane standing beside it (`tools/suite_scenes.py
/// --tests`): the floor sees the ball up close, directly and through the pane. The cosine ray
/// stops at the pane, so light through one is the emitter sample's alone (`through_panes`
/// says where it came through one). Without the ray here (`rppm render` at 64², 16
/// iterations): relMSE 0.104 and 0.063, energy 1.040 and 1.017 by seed; with it 0.022 and
/// 0.023, 1.007 and 1.006.
#[test]
fn a_glowing_ball_beside_a_pane_has_no_fireflies() {
    room_within("lamp_by_pane", 64, 16, 0.04, 0.97..=1.03);
}

/// A ceiling emitter whose edge crosses the image's top row (room 1 of `random_scenes.py
/// --seed 40`: a spot light, a near-mirror ball, a dark glossy floor), a sliver a row high
/// that each iteration's jitter meets in a few pixels or none. The outlier spread took what
/// the second iteration met of it for a rare path's light and smeared it over the ceiling, a
/// glow three rows deep (relMSE 2.24 after 2 iterations, 0.56 after 4). An emitter the camera
/// sees is where it is, and is not spread now: 0.0050 and 0.0039.
#[test]
fn an_emitter_at_the_images_edge_does_not_glow() {
    room_within("r40_01", 64, 2, 0.02, 0.97..=1.05);
}

/// The room `name` kept in `assets/suite/random/` against its reference
/// (`against_reference`): relMSE under `max_error`, energy ratio within `energy`.
fn room_within(
    name: &str,
    size: u32,
    iterations: u32,
    max_error: f64,
    energy: RangeInclusive<f64>,
) {
    let room = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/suite/random");
    let (error, ratio) = against_reference(
        &format!("random room {name}"),
        room.join(format!("{name}.gltf")),
        &room.join(format!("{name}.ref.exr")),
        size,
        iterations,
    );
    assert!(
        error < max_error && energy.contains(&ratio),
        "{name}: relMSE {error:.4}, energy {ratio:.4}"
    );
}
