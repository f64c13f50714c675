//! `rppm bench dirt`: the settings it sweeps and its table.

use bevy_rppm::cubemap::CubemapConfig;
use bevy_rppm::debug::bench::{CubemapBenchRow, Tracer};

/// `default` first, then every resolution × bins pair not equal to it.
pub fn sweep_configs(
    default: CubemapConfig,
    resolutions: &[u32],
    bins: &[u32],
) -> Vec<CubemapConfig> {
    let mut configs = vec![default];
    for &resolution in resolutions {
        for &bins in bins {
            let config = CubemapConfig {
                resolution,
                tile_size: default.tile_size,
                bins,
            };
            if !configs.contains(&config) {
                configs.push(config);
            }
        }
    }
    configs
}

/// One row per setting (and the hierarchy's): agreement with brute force, build and trace
/// time, memory.
pub fn print_table(rows: &[CubemapBenchRow]) {
    println!(
        "{:>12} {:>5} {:>4} {:>4} {:>9} {:>6} {:>6} {:>6} {:>10} {:>12} {:>10}",
        "tracer",
        "res",
        "tile",
        "bins",
        "agreement",
        "f.miss",
        "f.hit",
        "wrong",
        "build ms",
        "trace ms/1M",
        "MiB"
    );
    for r in rows {
        let tracer = match r.tracer {
            Tracer::DeepCubemap => "deep cubemap",
            Tracer::Bvh => "BVH (CPU)",
        };
        println!(
            "{:>12} {:>5} {:>4} {:>4} {:>9.5} {:>6} {:>6} {:>6} {:>10.2} {:>12.1} {:>10.1}",
            tracer,
            r.resolution,
            r.tile_size,
            r.bins,
            r.agreement,
            r.false_misses,
            r.false_hits,
            r.wrong_hits,
            r.build_ms,
            r.trace_ms * (1 << 20) as f64 / r.timing_rays.max(1) as f64,
            r.bytes as f64 / (1 << 20) as f64
        );
    }
}
