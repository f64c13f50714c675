//! `rppm`: render a glTF scene headless with progressive photon mapping.
//!
//! ```text
//! rppm render SCENE.gltf [--width W] [--height H] [--iterations N | --time-budget SECONDS]
//!                        [--out FILE.exr|FILE.png]... [--stats FILE.json]
//! rppm                   renders assets/cornell_box.gltf (256², 32 iterations of 65 536 photons)
//!                        to out/cornell_box.{exr,png,json}
//! ```

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use bevy_rppm::cubemap::CubemapConfig;
use bevy_rppm::cubemap::bench::DirtBenchRow;
use bevy_rppm::headless::{Budget, RenderRequest, RenderResult, bench_dirt, render_gltf};
use bevy_rppm::image_io::{bad_pixels, energy_ratio, read_exr, relmse, write_exr, write_png};
use bevy_rppm::trade::{TradeRequest, best_at, pareto_front, run_trade, write_csv};
use bevy_rppm::{PhotonMapping, RppmDebugView, RppmPreset};

const USAGE: &str = "usage: rppm render SCENE.gltf [--width W] [--height H] \
[--iterations N | --time-budget SECONDS] [--out FILE.exr|FILE.png]... [--stats FILE.json]
                   [--photons N] [--photon-depth N] [--radius PIXELS] [--cubemap RESOLUTION] [--splat-rr]
                   [--debug-view gbuffer-normals|cubemap-normals|direct-photons] [--preset preview|balanced|reference]
                   [--alpha A] [--bins N] [--tile 1|2|4] [--eye-depth N] [--flattening F] [--subsampling 1|2|4]
       rppm compare TEST.exr REFERENCE.exr
       rppm bench trade SCENE.gltf --reference REF.exr [--budget SECONDS] [--out DIR] [--knobs photons,cubemap,...] [--photons N]
       rppm bench dirt SCENE.gltf [--json] [--rays N] [--timing-rays N] \
[--resolutions 64,128,256,512] [--bins 4,8,16,32] [--tile 1|2|4]";

const DEFAULT_SCENE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/cornell_box.gltf");

struct Args {
    request: RenderRequest,
    outputs: Vec<PathBuf>,
    stats: Option<PathBuf>,
}

fn main() -> ExitCode {
    let argv: Vec<String> = std::env::args().skip(1).collect();
    let parsed = match argv.first().map(String::as_str) {
        None => Ok(default_args()),
        Some("render") => parse_render(&argv[1..]),
        Some("compare") => {
            return match compare(&argv[1..]) {
                Ok(()) => ExitCode::SUCCESS,
                Err(message) => {
                    eprintln!("rppm: error: {message}");
                    ExitCode::from(2)
                }
            };
        }
        Some("bench") => {
            let result = match argv.get(1).map(String::as_str) {
                Some("dirt") => parse_bench(&argv[2..]).and_then(|b| bench(&b)),
                Some("trade") => parse_trade(&argv[2..]).and_then(|t| trade(&t)),
                _ => Err(format!(
                    "bench what? use 'bench dirt' or 'bench trade'\n{USAGE}"
                )),
            };
            return match result {
                Ok(()) => ExitCode::SUCCESS,
                Err(message) => {
                    eprintln!("rppm: error: {message}");
                    ExitCode::from(2)
                }
            };
        }
        Some("-h" | "--help" | "help") => {
            println!("{USAGE}");
            return ExitCode::SUCCESS;
        }
        Some(other) => Err(format!("unknown command '{other}'\n{USAGE}")),
    };
    let result = parsed.and_then(|args| run(&args));
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("rppm: error: {message}");
            ExitCode::from(2)
        }
    }
}

fn default_args() -> Args {
    let out = PathBuf::from("out");
    Args {
        request: RenderRequest {
            scene: PathBuf::from(DEFAULT_SCENE),
            width: 256,
            height: 256,
            budget: Budget::Iterations(32),
            settings: PhotonMapping {
                photons_per_iteration: 65_536,
                ..PhotonMapping::default()
            },
        },
        outputs: vec![out.join("cornell_box.exr"), out.join("cornell_box.png")],
        stats: Some(out.join("cornell_box.json")),
    }
}

fn value<'a>(args: &'a [String], i: usize, flag: &str) -> Result<&'a str, String> {
    args.get(i + 1)
        .map(String::as_str)
        .ok_or_else(|| format!("{flag} needs a value\n{USAGE}"))
}

fn number<T: std::str::FromStr>(text: &str, flag: &str) -> Result<T, String> {
    text.parse()
        .map_err(|_| format!("{flag}: '{text}' is not a valid number"))
}

fn parse_render(args: &[String]) -> Result<Args, String> {
    let mut scene = None;
    let (mut width, mut height) = (512u32, 512u32);
    let mut budget = None;
    let mut outputs = Vec::new();
    let mut stats = None;
    let mut settings = PhotonMapping::default();
    let mut i = 0;
    while i < args.len() {
        let flag = args[i].as_str();
        match flag {
            "--width" => width = number(value(args, i, flag)?, flag)?,
            "--height" => height = number(value(args, i, flag)?, flag)?,
            "--iterations" => {
                let n: u32 = number(value(args, i, flag)?, flag)?;
                if n == 0 {
                    return Err("--iterations must be at least 1".into());
                }
                budget = set_budget(budget, Budget::Iterations(n))?;
            }
            "--time-budget" => {
                let s: f64 = number(value(args, i, flag)?, flag)?;
                if !(s.is_finite() && s > 0.0) {
                    return Err("--time-budget must be a positive number of seconds".into());
                }
                budget = set_budget(budget, Budget::Seconds(s))?;
            }
            "--out" => outputs.push(output_path(value(args, i, flag)?)?),
            "--stats" => stats = Some(PathBuf::from(value(args, i, flag)?)),
            "--photons" => settings.photons_per_iteration = number(value(args, i, flag)?, flag)?,
            "--photon-depth" => settings.max_photon_depth = number(value(args, i, flag)?, flag)?,
            "--radius" => settings.initial_radius_pixels = number(value(args, i, flag)?, flag)?,
            "--cubemap" => settings.cubemap_resolution = number(value(args, i, flag)?, flag)?,
            "--alpha" => settings.alpha = number(value(args, i, flag)?, flag)?,
            "--bins" => settings.bins = number(value(args, i, flag)?, flag)?,
            "--tile" => settings.cubemap_tile_size = number(value(args, i, flag)?, flag)?,
            "--eye-depth" => settings.max_eye_depth = number(value(args, i, flag)?, flag)?,
            "--flattening" => settings.kernel_flattening = number(value(args, i, flag)?, flag)?,
            "--subsampling" => settings.indirect_subsampling = number(value(args, i, flag)?, flag)?,
            "--preset" => {
                settings = PhotonMapping::from(match value(args, i, flag)? {
                    "preview" => RppmPreset::Preview,
                    "balanced" => RppmPreset::Balanced,
                    "reference" => RppmPreset::Reference,
                    other => {
                        return Err(format!(
                            "--preset {other}: use preview, balanced or reference"
                        ));
                    }
                })
            }
            "--splat-rr" => {
                settings.splat_russian_roulette = true;
                i += 1;
                continue;
            }
            "--debug-view" => {
                settings.debug_view = match value(args, i, flag)? {
                    "gbuffer-normals" => RppmDebugView::GBufferNormals,
                    "cubemap-normals" => RppmDebugView::CubemapNormals,
                    "direct-photons" => RppmDebugView::DirectPhotons,
                    other => {
                        return Err(format!(
                            "--debug-view {other}: use gbuffer-normals, cubemap-normals or \
                             direct-photons"
                        ));
                    }
                }
            }
            _ => {
                i += positional(flag, &mut scene)?;
                continue;
            }
        }
        i += 2;
    }
    let scene = scene.ok_or_else(|| format!("no scene given\n{USAGE}"))?;
    Ok(Args {
        request: RenderRequest {
            scene,
            width,
            height,
            budget: budget.unwrap_or(Budget::Iterations(16)),
            settings,
        },
        outputs,
        stats,
    })
}

/// A bare argument: the scene, once; anything else (an unknown option, a second scene) is an
/// error. Returns the arguments it used.
fn positional(flag: &str, scene: &mut Option<PathBuf>) -> Result<usize, String> {
    if flag.starts_with("--") {
        return Err(format!("unknown option {flag}\n{USAGE}"));
    }
    if scene.is_some() {
        return Err(format!("unexpected argument '{flag}'\n{USAGE}"));
    }
    *scene = Some(PathBuf::from(flag));
    Ok(1)
}

fn set_budget(current: Option<Budget>, new: Budget) -> Result<Option<Budget>, String> {
    match current {
        None => Ok(Some(new)),
        Some(_) => Err("give either --iterations or --time-budget, not both".into()),
    }
}

fn output_path(text: &str) -> Result<PathBuf, String> {
    let path = PathBuf::from(text);
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("exr" | "png") => Ok(path),
        _ => Err(format!("--out {text}: the file must end in .exr or .png")),
    }
}

fn run(args: &Args) -> Result<(), String> {
    let started = std::time::Instant::now();
    let result = render_gltf(&args.request, |progress| {
        let iteration = progress.iteration;
        let line = match progress.budget {
            Budget::Iterations(n) => {
                let filled = (iteration as usize * 30) / (n as usize).max(1);
                format!(
                    "[{:<30}] {iteration}/{n} iterations",
                    "#".repeat(filled.min(30))
                )
            }
            Budget::Seconds(s) => format!("{iteration} iterations (budget {s} s)"),
        };
        eprint!("\r{line}");
        let _ = std::io::stderr().flush();
    })?;
    eprintln!();
    for path in &args.outputs {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir)
                .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        }
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("png") => write_png(path, &result.image)?,
            _ => write_exr(path, &result.image)?,
        }
        eprintln!("wrote {}", path.display());
    }
    if let Some(path) = &args.stats {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir)
                .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        }
        let json = stats_json(args, &result, started.elapsed().as_secs_f64());
        std::fs::write(
            path,
            serde_json::to_string_pretty(&json).unwrap_or_default(),
        )
        .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        eprintln!("wrote {}", path.display());
    }
    eprintln!(
        "{} iterations in {:.2} s ({:.1} s in all) on {}",
        result.iterations,
        result.seconds,
        started.elapsed().as_secs_f64(),
        result.stats.adapter
    );
    Ok(())
}

fn stats_json(args: &Args, r: &RenderResult, total_seconds: f64) -> serde_json::Value {
    serde_json::json!({
        "scene": args.request.scene.display().to_string(),
        "width": r.image.width,
        "height": r.image.height,
        "iterations": r.iterations,
        "render_seconds": r.seconds,
        "total_seconds": total_seconds,
        "adapter": r.stats.adapter,
        "gpu_timing": r.stats.gpu_timing,
        "gpu_ms_last_frame": r.stats.stage_ms,
        "iterations_last_frame": r.stats.iterations_this_frame,
        "gpu_ms_per_iteration": per_iteration(&r.stats),
        "timed_iterations": r.stats.timed_iterations,
        "memory_bytes": r.stats.memory,
        "camera_from_scene": r.camera_from_scene,
        "triangles": r.triangles,
        "lights": r.lights,
        "emitters": r.emitters,
        "bad_pixels": bad_pixels(&r.image),
        "cubemap_nodes": r.stats.cubemap_nodes,
        "cubemap_overflow": r.stats.cubemap_overflow,
        "photons_per_iteration": r.stats.photons_per_iteration,
        "photons_stored": r.stats.photons_stored,
        "importons": r.stats.importons,
        "passes": r.stats.passes,
        "shader_paths": r.stats.shader_paths,
        "mean_rgb": mean_rgb(&r.image),
    })
}

/// Mean GPU ms per iteration and stage, over every timed frame.
fn per_iteration(stats: &bevy_rppm::ViewStats) -> serde_json::Value {
    let n = stats.timed_iterations.max(1) as f64;
    stats
        .stage_ms_total
        .iter()
        .map(|(stage, ms)| (stage.clone(), serde_json::json!(ms / n)))
        .collect::<serde_json::Map<_, _>>()
        .into()
}

fn mean_rgb(image: &bevy_rppm::image_io::RgbImage) -> [f64; 3] {
    let n = image.pixels.len().max(1) as f64;
    let mut sum = [0.0f64; 3];
    for p in &image.pixels {
        for c in 0..3 {
            sum[c] += p[c] as f64;
        }
    }
    sum.map(|s| s / n)
}

struct BenchArgs {
    scene: PathBuf,
    json: bool,
    rays: u32,
    timing_rays: u32,
    resolutions: Vec<u32>,
    bins: Vec<u32>,
    tile: u32,
}

fn list(text: &str, flag: &str) -> Result<Vec<u32>, String> {
    text.split(',').map(|v| number(v.trim(), flag)).collect()
}

fn parse_bench(args: &[String]) -> Result<BenchArgs, String> {
    let mut b = BenchArgs {
        scene: PathBuf::new(),
        json: false,
        rays: 1 << 16,
        timing_rays: 1 << 20,
        resolutions: vec![64, 128, 256, 512],
        bins: vec![4, 8, 16, 32],
        tile: 1,
    };
    let mut scene = None;
    let mut i = 0;
    while i < args.len() {
        let flag = args[i].as_str();
        let mut step = 2;
        match flag {
            "--json" => {
                b.json = true;
                step = 1;
            }
            "--rays" => b.rays = number(value(args, i, flag)?, flag)?,
            "--timing-rays" => b.timing_rays = number(value(args, i, flag)?, flag)?,
            "--resolutions" => b.resolutions = list(value(args, i, flag)?, flag)?,
            "--bins" => b.bins = list(value(args, i, flag)?, flag)?,
            "--tile" => b.tile = number(value(args, i, flag)?, flag)?,
            _ => step = positional(flag, &mut scene)?,
        }
        i += step;
    }
    b.scene = scene.ok_or_else(|| format!("no scene given\n{USAGE}"))?;
    if !(1..=1 << 24).contains(&b.rays) || !(1..=1 << 26).contains(&b.timing_rays) {
        return Err("--rays must be in 1..=16777216 and --timing-rays in 1..=67108864".into());
    }
    if ![1, 2, 4].contains(&b.tile) {
        return Err("--tile must be 1, 2 or 4".into());
    }
    if b.resolutions.iter().any(|r| !(16..=4096).contains(r))
        || b.bins.iter().any(|n| !(1..=64).contains(n))
    {
        return Err("resolutions must be in 16..=4096 and bins in 1..=64".into());
    }
    Ok(b)
}

fn bench(b: &BenchArgs) -> Result<(), String> {
    let defaults = PhotonMapping::default();
    let default = CubemapConfig {
        resolution: defaults.cubemap_resolution,
        tile_size: b.tile,
        bins: defaults.bins,
    };
    let mut configs = vec![default];
    for &resolution in &b.resolutions {
        for &bins in &b.bins {
            let config = CubemapConfig {
                resolution,
                tile_size: b.tile,
                bins,
            };
            if !configs.contains(&config) {
                configs.push(config);
            }
        }
    }
    eprintln!(
        "rppm: tracing {} rays per setting through {} settings...",
        b.rays,
        configs.len()
    );
    let (rows, centre) = bench_dirt(&b.scene, configs, b.rays, b.timing_rays)?;
    if b.json {
        let json = serde_json::json!({
            "scene": b.scene.display().to_string(),
            "centre": centre.to_array(),
            "default": rows.first(),
            "settings": rows,
        });
        println!(
            "{}",
            serde_json::to_string_pretty(&json).unwrap_or_default()
        );
    } else {
        print_table(&rows);
    }
    Ok(())
}

fn print_table(rows: &[DirtBenchRow]) {
    println!(
        "{:>5} {:>4} {:>4} {:>9} {:>6} {:>6} {:>6} {:>10} {:>12} {:>10}",
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
        println!(
            "{:>5} {:>4} {:>4} {:>9.5} {:>6} {:>6} {:>6} {:>10.2} {:>12.1} {:>10.1}",
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

/// Prints the metrics of shared/docs/CONVENTIONS.md for a test image against a reference.
fn compare(args: &[String]) -> Result<(), String> {
    let [test, reference] = args else {
        return Err(format!("compare needs two EXR files\n{USAGE}"));
    };
    let (test, reference) = (read_exr(test.as_ref())?, read_exr(reference.as_ref())?);
    let json = serde_json::json!({
        "relmse": relmse(&test, &reference)?,
        "energy_ratio": energy_ratio(&test, &reference)?,
        "bad_pixels": bad_pixels(&test),
    });
    println!("{json}");
    Ok(())
}

struct TradeArgs {
    request: TradeRequest,
    out: PathBuf,
}

fn parse_trade(args: &[String]) -> Result<TradeArgs, String> {
    let (mut scene, mut reference) = (None, None);
    let mut budget = 20.0f64;
    let mut out = PathBuf::from("out/trade");
    let mut only = Vec::new();
    let mut base = PhotonMapping::default();
    let mut i = 0;
    while i < args.len() {
        let flag = args[i].as_str();
        match flag {
            "--reference" => reference = Some(PathBuf::from(value(args, i, flag)?)),
            "--budget" => budget = number(value(args, i, flag)?, flag)?,
            "--out" => out = PathBuf::from(value(args, i, flag)?),
            "--knobs" => only = value(args, i, flag)?.split(',').map(String::from).collect(),
            "--photons" => base.photons_per_iteration = number(value(args, i, flag)?, flag)?,
            _ => {
                i += positional(flag, &mut scene)?;
                continue;
            }
        }
        i += 2;
    }
    if !(budget.is_finite() && budget > 0.0) {
        return Err("--budget must be a positive number of seconds".into());
    }
    let names: Vec<&str> = bevy_rppm::trade::knobs(&base)
        .iter()
        .map(|k| k.name)
        .collect();
    if let Some(unknown) = only.iter().find(|k| !names.contains(&k.as_str())) {
        return Err(format!(
            "--knobs: no knob '{unknown}'; knobs: {}",
            names.join(",")
        ));
    }
    let scene = scene.ok_or_else(|| format!("no scene given\n{USAGE}"))?;
    let reference = reference.ok_or_else(|| format!("--reference REF.exr is required\n{USAGE}"))?;
    Ok(TradeArgs {
        request: TradeRequest {
            scene,
            reference: read_exr(&reference)?,
            budget_seconds: budget,
            base,
            only,
        },
        out,
    })
}

/// Sweeps the knobs, writes the CSVs and plots, and prints the best setting per budget.
fn trade(t: &TradeArgs) -> Result<(), String> {
    std::fs::create_dir_all(&t.out)
        .map_err(|e| format!("cannot create {}: {e}", t.out.display()))?;
    let runs = run_trade(&t.request, |line| eprintln!("{line}"));
    if runs.iter().all(|r| r.error.is_some()) {
        return Err(format!(
            "every run failed: {}",
            runs.first()
                .and_then(|r| r.error.clone())
                .unwrap_or_default()
        ));
    }
    write_csv(&runs, &t.out)?;
    let front = pareto_front(&runs);
    for path in bevy_rppm::trade::plot::write_plots(&runs, &front, &t.out)? {
        eprintln!("wrote {path}");
    }
    eprintln!("wrote {}/samples.csv and runs.csv", t.out.display());
    println!("budget_s  best setting          iterations  relMSE");
    let budget = t.request.budget_seconds;
    let budgets = [1.0, 2.0, 5.0, 10.0, budget];
    for b in budgets.into_iter().filter(|&b| b <= budget) {
        if let Some((run, sample)) = best_at(&runs, b) {
            println!(
                "{b:>8.1}  {:<20}  {:>10}  {:.5}",
                format!("{}={}", run.knob, run.value),
                sample.iteration,
                sample.relmse
            );
        }
    }
    Ok(())
}
