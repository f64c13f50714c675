use super::util::*;

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
    let (rows, _) = bevy_rppm_cli::headless::bench_dirt(&scene, configs, 8192, 8192).unwrap();
    assert_eq!(rows.len(), 2);
    for row in rows {
        eprintln!("{row:?}");
        assert!(row.agreement >= 0.999, "{row:?}");
        assert_eq!(row.false_hits, 0, "{row:?}");
    }
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
