//! `rppm`: render a glTF scene headless with progressive photon mapping, compare images, and
//! bench the deep cubemap and the speed/accuracy trade. `rppm --help` lists the commands.

mod args;

use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use bevy_rppm::cubemap::CubemapConfig;
use bevy_rppm::{InitialRadius, IterationsPerFrame, PhotonCount, PhotonMapping, ViewStats};
use bevy_rppm_cli::animation;
use bevy_rppm_cli::bench::{print_table, sweep_configs};
use bevy_rppm_cli::headless::{
    Budget, Progress, RenderResult, bench_dirt, check_size, render_loaded,
};
use bevy_rppm_cli::image_io::{RgbImage, bad_pixels, read_exr, write_exr, write_png};
use bevy_rppm_cli::load::load_gltf_with;
use bevy_rppm_cli::trade::{
    TradeRequest, best_at, knobs, pareto_front, read_csv, run_trade, write_csv,
};
use bevy_rppm_cli::validate::{Access, check_gltf};
use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use args::{
    BenchCommand, Cli, Command, DirtArgs, InputsArgs, MotionArgs, MotionScript, RenderArgs,
    SuiteArgs, TradeArgs, default_render, extension,
};

/// The first panic's message and place, for the error line.
static LAST_PANIC: std::sync::Mutex<Option<String>> = std::sync::Mutex::new(None);

fn main() -> ExitCode {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        // libwayland, loaded by the Vulkan drivers, prints an error line of its own without
        // it; rppm draws no window.
        // SAFETY: no other thread runs yet.
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir()) };
    }
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            // --help, --version
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            // clap's message in one line, as every other error.
            let text = e.render().to_string();
            let lines: Vec<&str> = text
                .lines()
                .take_while(|l| !l.trim().is_empty())
                .map(str::trim)
                .collect();
            eprintln!("rppm: {} (see rppm --help)", lines.join(" "));
            return ExitCode::from(2);
        }
    };
    // A panic (inside Bevy's loader, say) becomes the one error line, without the default
    // hook's message and backtrace.
    std::panic::set_hook(Box::new(|info| {
        let message = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_default();
        let at = info
            .location()
            .map(|l| format!(" at {l}"))
            .unwrap_or_default();
        if let Ok(mut last) = LAST_PANIC.lock() {
            last.get_or_insert(format!("{message}{at}"));
        }
    }));
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| match cli.command {
        None => render(&default_render()),
        Some(Command::Render(args)) => render(&args),
        Some(Command::Compare {
            test,
            reference,
            blocks,
        }) => bevy_rppm_cli::suite::compare(&test, &reference, blocks),
        Some(Command::Bench(BenchCommand::Dirt(args))) => dirt(&args),
        Some(Command::Bench(BenchCommand::Trade(args))) => trade(&args),
        Some(Command::Bench(BenchCommand::Plot { dir })) => plot(&dir),
        Some(Command::Bench(BenchCommand::Motion(args))) => motion(&args),
        Some(Command::Bench(BenchCommand::Suite(args))) => suite(&args),
        Some(Command::Bench(BenchCommand::Inputs(args))) => inputs(&args),
    }))
    .unwrap_or_else(|_| Err(anyhow::anyhow!("internal error")));
    let panic = LAST_PANIC.lock().ok().and_then(|mut p| p.take());
    let result = match (result, panic) {
        (Err(e), Some(panic)) => Err(anyhow::anyhow!("{e:#} (internal error: {panic})")),
        (result, _) => result,
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("rppm: error: {e:#}");
            ExitCode::from(2)
        }
    }
}

/// A progress bar on stderr (hidden when it is not a terminal): iterations against the budget,
/// iterations per second and the time left.
fn progress_bar(budget: Budget) -> ProgressBar {
    let (len, template) = match budget {
        Budget::Iterations(n) => (
            n as u64,
            "[{bar:30}] {pos}/{len} iterations, {per_sec}, ETA {eta}",
        ),
        Budget::Seconds(s) => ((s * 1000.0) as u64, "[{bar:30}] {msg}, ETA {eta}"),
    };
    let style = ProgressStyle::with_template(template)
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("#>-");
    ProgressBar::new(len).with_style(style)
}

/// The stats JSON: the render's own numbers and the view's stats, one key per field.
#[derive(Serialize)]
struct RenderStats<'a> {
    scene: String,
    width: usize,
    height: usize,
    iterations: u32,
    render_seconds: f64,
    total_seconds: f64,
    /// Mean GPU ms per iteration and stage, over every timed frame.
    gpu_ms_per_iteration: std::collections::BTreeMap<String, f64>,
    camera_from_scene: bool,
    triangles: usize,
    lights: usize,
    emitters: usize,
    bad_pixels: usize,
    mean_rgb: [f64; 3],
    #[serde(flatten)]
    view: &'a ViewStats,
}

fn render(args: &RenderArgs) -> Result<()> {
    for path in args.out.iter().chain(&args.stats) {
        writable(path)?;
    }
    let started = std::time::Instant::now();
    let request = args.request();
    let bar = progress_bar(request.budget);
    let progress = |p: &Progress| match p.budget {
        Budget::Iterations(_) => bar.set_position(p.iteration as u64),
        Budget::Seconds(_) => {
            bar.set_position((p.seconds * 1000.0) as u64);
            let rate = p.iteration as f64 / p.seconds.max(1e-9);
            bar.set_message(format!("{} iterations, {rate:.2} it/s", p.iteration));
        }
    };
    let access = Access {
        outside_files: args.allow_outside_files,
    };
    let result = check_size(&request)
        .and_then(|()| load_gltf_with(&request.scene, access))
        .and_then(|mut app| {
            if let Some(index) = args.animation {
                let clip = animation::pose(&mut app, &request.scene, index, args.animation_time)?;
                let (name, at) = (clip.name, args.animation_time);
                bar.suspend(|| eprintln!("posed by animation {name} at {at} s"));
            }
            render_loaded(&mut app, &request, progress)
        })
        .map_err(anyhow::Error::msg)?;
    bar.finish_and_clear();
    for path in &args.out {
        match extension(path).as_deref() {
            Some("png") => write_png(path, &result.image),
            _ => write_exr(path, &result.image),
        }
        .map_err(anyhow::Error::msg)?;
        eprintln!("wrote {}", path.display());
    }
    if let Some(path) = &args.stats {
        let json = stats_json(args, &result, started.elapsed().as_secs_f64());
        std::fs::write(path, serde_json::to_string_pretty(&json)?)
            .with_context(|| format!("cannot write {}", path.display()))?;
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

/// Makes the file's folder, so that a path that cannot be written fails before the render.
/// Makes `path`'s folder and tries the file, so that a path that cannot be written fails
/// before the render rather than after it.
fn writable(path: &Path) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    let existed = path.exists();
    std::fs::OpenOptions::new()
        .append(true)
        .create(true)
        .open(path)
        .with_context(|| format!("cannot write {}", path.display()))?;
    if !existed {
        let _ = std::fs::remove_file(path);
    }
    Ok(())
}

fn stats_json<'a>(args: &RenderArgs, r: &'a RenderResult, total_seconds: f64) -> RenderStats<'a> {
    let n = r.stats.timed_iterations.max(1) as f64;
    RenderStats {
        scene: args.scene.display().to_string(),
        width: r.image.width,
        height: r.image.height,
        iterations: r.iterations,
        render_seconds: r.seconds,
        total_seconds,
        gpu_ms_per_iteration: r
            .stats
            .stage_ms_total
            .iter()
            .map(|(stage, ms)| (stage.clone(), ms / n))
            .collect(),
        camera_from_scene: r.camera_from_scene,
        triangles: r.triangles,
        lights: r.lights,
        emitters: r.emitters,
        bad_pixels: bad_pixels(&r.image),
        mean_rgb: mean_rgb(&r.image),
        view: &r.stats,
    }
}

fn mean_rgb(image: &RgbImage) -> [f64; 3] {
    let n = image.pixels.len().max(1) as f64;
    let mut sum = [0.0f64; 3];
    for p in &image.pixels {
        for c in 0..3 {
            sum[c] += p[c] as f64;
        }
    }
    sum.map(|s| s / n)
}

#[derive(Serialize)]
struct DirtReport<'a> {
    scene: String,
    centre: [f32; 3],
    default: Option<&'a bevy_rppm::debug::bench::CubemapBenchRow>,
    settings: &'a [bevy_rppm::debug::bench::CubemapBenchRow],
}

fn dirt(args: &DirtArgs) -> Result<()> {
    check_gltf(&args.scene, Access::default()).map_err(anyhow::Error::msg)?;
    let defaults = PhotonMapping::default();
    let default = CubemapConfig {
        resolution: defaults.cubemap_resolution,
        tile_size: args.tile,
        bins: defaults.bins,
    };
    let configs = sweep_configs(default, &args.resolutions, &args.bins);
    if !args.json {
        eprintln!(
            "rppm: tracing {} rays per setting through {} settings...",
            args.rays,
            configs.len()
        );
    }
    let (rows, centre) = bench_dirt(&args.scene, configs, args.rays, args.timing_rays)
        .map_err(anyhow::Error::msg)?;
    if args.json {
        let report = DirtReport {
            scene: args.scene.display().to_string(),
            centre: centre.to_array(),
            default: rows.first(),
            settings: &rows,
        };
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print_table(&rows);
    }
    Ok(())
}

fn write_plots(runs: &[bevy_rppm_cli::trade::Run], dir: &Path) -> Result<()> {
    let front = pareto_front(runs);
    for path in
        bevy_rppm_cli::trade::plot::write_plots(runs, &front, dir).map_err(anyhow::Error::msg)?
    {
        eprintln!("wrote {path}");
    }
    Ok(())
}

fn plot(dir: &Path) -> Result<()> {
    let runs = read_csv(dir)?;
    if runs.is_empty() {
        bail!("{} holds no samples", dir.join("samples.csv").display());
    }
    write_plots(&runs, dir)
}

/// Sweeps the knobs, writes the CSVs and plots, and prints the best setting per budget.
fn trade(args: &TradeArgs) -> Result<()> {
    check_gltf(&args.scene, Access::default()).map_err(anyhow::Error::msg)?;
    let mut base = PhotonMapping::default();
    // Runs compare settings, so the photon count is fixed: 262 144 unless `--photons`.
    base.photons_per_iteration =
        PhotonCount::Fixed(args.photons.unwrap_or(base.photons_per_iteration.max()));
    let names: Vec<&str> = knobs(&base).iter().map(|k| k.name).collect();
    if let Some(unknown) = args.knobs.iter().find(|k| !names.contains(&k.as_str())) {
        bail!("--knobs: no knob '{unknown}'; knobs: {}", names.join(","));
    }
    let request = TradeRequest {
        scene: args.scene.clone(),
        reference: read_exr(&args.reference).map_err(anyhow::Error::msg)?,
        budget_seconds: args.budget,
        base,
        only: args.knobs.clone(),
    };
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let runs = run_trade(&request, |line| eprintln!("{line}"));
    if runs.iter().all(|r| r.error.is_some()) {
        bail!(
            "every run failed: {}",
            runs.first()
                .and_then(|r| r.error.clone())
                .unwrap_or_default()
        );
    }
    write_csv(&runs, &args.out)?;
    write_plots(&runs, &args.out)?;
    eprintln!("wrote {}/samples.csv and runs.csv", args.out.display());
    println!("budget_s  best setting          iterations  relMSE");
    let budgets = [1.0, 2.0, 5.0, 10.0, args.budget];
    for b in budgets.into_iter().filter(|&b| b <= args.budget) {
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

fn inputs(args: &InputsArgs) -> Result<()> {
    use bevy_rppm_cli::catalogue::{default_root, listing, run_cases, select, table};
    let cases = select(args.all, args.filter.as_deref());
    if args.list {
        print!("{}", listing(&cases));
        return Ok(());
    }
    let rppm = std::env::current_exe().context("finding rppm itself")?;
    let root = args.dir.clone().unwrap_or_else(default_root);
    let limit = std::time::Duration::from_secs_f64(args.limit);
    let verdicts = run_cases(&rppm, &cases, &root, limit, |v| {
        let mark = if v.passed { "pass" } else { "FAIL" };
        eprintln!("{mark} {:5.1} s  {}: {}", v.seconds, v.name, v.detail);
    });
    let text = table(&verdicts);
    println!("{text}");
    if let Some(path) = &args.table {
        std::fs::write(path, &text).with_context(|| format!("cannot write {}", path.display()))?;
    }
    if args.dir.is_none() {
        let _ = std::fs::remove_dir_all(&root);
    }
    let failed = verdicts.iter().filter(|v| !v.passed).count();
    if failed > 0 {
        bail!("{failed} of {} cases failed", verdicts.len());
    }
    Ok(())
}

fn suite(args: &SuiteArgs) -> Result<()> {
    use bevy_rppm_cli::suite::{find_scenes, run_scene, table};
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let dirs = if args.dirs.is_empty() {
        vec![root.join("assets/suite"), root.join("../shared/scenes")]
            .into_iter()
            .filter(|d| d.is_dir())
            .collect()
    } else {
        args.dirs.clone()
    };
    let scenes = find_scenes(&dirs)?;
    let tool = root.join("tools/reference.py");
    let mitsuba = (!args.no_path_tracer).then_some((tool.as_path(), args.variant.as_str()));
    let mut rows = Vec::new();
    for scene in &scenes {
        eprintln!("rppm: {} ({} s each)", scene.name, args.budget);
        let settings = PhotonMapping {
            tracer: args.tracer.into(),
            iterations_per_frame: args.frame.iterations_per_frame(),
            ..PhotonMapping::default()
        };
        rows.push(run_scene(
            scene,
            &settings,
            args.budget,
            mitsuba,
            &args.out,
        )?);
    }
    let text = table(&rows, args.budget);
    print!("{text}");
    if let Some(path) = &args.table {
        std::fs::write(path, &text).with_context(|| format!("cannot write {}", path.display()))?;
    }
    Ok(())
}

fn motion(args: &MotionArgs) -> Result<()> {
    use bevy_rppm_cli::motion::{
        MotionRequest, Script, bench_motion, print_report, write_csv, write_images, write_plot,
    };
    check_gltf(&args.scene, Access::default()).map_err(anyhow::Error::msg)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let script = match args.script {
        MotionScript::Orbit => Script::Orbit,
        MotionScript::Light => Script::Light,
        MotionScript::Animation => Script::Animation(args.animation),
        MotionScript::Slide => Script::Slide(args.object.clone()),
    };
    let request = MotionRequest {
        scene: args.scene.clone(),
        script: script.clone(),
        frames: args.frames,
        every: args.every,
        width: args.width,
        height: args.height,
        settings: PhotonMapping {
            photons_per_iteration: PhotonCount::Fixed(args.photons),
            iterations_per_frame: IterationsPerFrame::Fixed(args.iterations_per_frame),
            seed: args.seed,
            initial_radius: args
                .radius
                .map_or(InitialRadius::default(), InitialRadius::Pixels),
            ..PhotonMapping::default()
        },
        window: args.window,
        reference_iterations: args.reference_iterations,
    };
    let result =
        bench_motion(&request, |step| eprintln!("rppm: {step}")).map_err(anyhow::Error::msg)?;
    print_report(&result, args.frames, &format!("{script:?}"));
    write_csv(&result, &args.out)?;
    let title = format!(
        "{}: {:?}, {}x{}, {} photons",
        args.scene.display(),
        script,
        args.width,
        args.height,
        args.photons
    );
    write_plot(&result, &args.out, &title).map_err(anyhow::Error::msg)?;
    write_images(&result, &args.out).map_err(anyhow::Error::msg)?;
    eprintln!(
        "wrote {}/motion.csv, motion.png and each sampled frame (frame<N>_reset|reuse|reference)",
        args.out.display()
    );
    Ok(())
}
