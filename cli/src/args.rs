//! The command line: commands, flags and their checks (clap), and the render settings they
//! give.

use std::path::{Path, PathBuf};

use bevy_rppm::{
    InitialRadius, IterationsPerFrame, PhotonCount, PhotonMapping, RppmDebugView, RppmPreset,
    RppmTracer,
};
use bevy_rppm_cli::headless::{Budget, RenderRequest};
use clap::{Args, Parser, Subcommand, ValueEnum};

/// Rasterisation-based progressive photon mapping, headless. With no command, renders the
/// default scene (the Cornell box, 256², 32 iterations of 65 536 photons) to
/// out/cornell_box.{exr,png,json}.
#[derive(Parser)]
#[command(name = "rppm", bin_name = "rppm", version)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Subcommand)]
pub enum Command {
    /// Render a glTF scene: raw linear radiance (EXR), a tonemapped preview (PNG), stats (JSON).
    Render(RenderArgs),
    /// relMSE, energy ratio and bad pixels of a test image against a reference (EXR, as in
    /// shared/docs/CONVENTIONS.md), as one JSON line.
    Compare {
        test: PathBuf,
        reference: PathBuf,
        /// Also where the error and energy lie: the image cut into N × N blocks, each with its
        /// share of the squared relative error and its energy ratio (row by row, from the top).
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..=64))]
        blocks: Option<u32>,
    },
    /// Benchmarks.
    #[command(subcommand)]
    Bench(BenchCommand),
}

#[derive(Subcommand)]
pub enum BenchCommand {
    /// Deep-cubemap (DIRT) traversal against brute force: agreement, build and trace time,
    /// memory, per cubemap setting.
    Dirt(DirtArgs),
    /// Every knob's speed/accuracy trade against a reference: CSVs, plots, the best setting
    /// per time budget.
    Trade(TradeArgs),
    /// Draws the trade's plots again from the samples.csv a `bench trade` wrote in DIR.
    Plot {
        /// The folder holding samples.csv; the plots are written beside it.
        dir: PathBuf,
    },
    /// A scripted animation under `Reset` and `Reuse`: each sampled frame's relMSE against
    /// the same frozen state rendered to convergence; a table, motion.csv and motion.png.
    Motion(MotionArgs),
    /// Every scene with a reference beside it (NAME.gltf, NAME.ref.exr) at an equal time
    /// budget: our relMSE and energy at default settings against Mitsuba 3's path tracer's
    /// relMSE in the same wall time; a Markdown table.
    Suite(SuiteArgs),
    /// The catalogue of bad and extreme input: each case's files, `rppm` run on them, and
    /// whether it kept the promise (one error line and exit 2, or an image of finite pixels;
    /// never a panic or a hang); a Markdown table.
    Inputs(InputsArgs),
}

#[derive(Args)]
pub struct InputsArgs {
    /// Also the slow cases (big scenes, big renders).
    #[arg(long)]
    pub all: bool,
    /// Only the cases whose name holds this text.
    #[arg(long)]
    pub filter: Option<String>,
    /// List the cases (group, name, what must happen) without running them.
    #[arg(long)]
    pub list: bool,
    /// Seconds a case may take before it counts as a hang.
    #[arg(long, default_value_t = 120.0, value_parser = positive_seconds)]
    pub limit: f64,
    /// Where the cases' files go (default: a temporary folder).
    #[arg(long)]
    pub dir: Option<PathBuf>,
    /// Write the table here too.
    #[arg(long)]
    pub table: Option<PathBuf>,
}

#[derive(Args)]
pub struct SuiteArgs {
    /// Folders of scenes and references (default: assets/suite and ../shared/scenes).
    pub dirs: Vec<PathBuf>,
    /// Wall-clock seconds each renderer gets per scene.
    #[arg(long, default_value_t = 60.0, value_parser = positive_seconds)]
    pub budget: f64,
    /// Only our renders, without Mitsuba.
    #[arg(long)]
    pub no_path_tracer: bool,
    /// What traces our rays (default: auto, today the BVH).
    #[arg(long, value_enum, default_value_t = Tracer::Auto)]
    pub tracer: Tracer,
    #[command(flatten)]
    pub frame: FrameArgs,
    /// Mitsuba's variant (`llvm_ad_rgb`, the fastest on a CPU, needs an LLVM that drjit accepts:
    /// `tools/reference.py` falls back to `scalar_rgb` without one).
    #[arg(long, default_value = "llvm_ad_rgb")]
    pub variant: String,
    /// Where Mitsuba's images go.
    #[arg(long, default_value = "out/suite")]
    pub out: PathBuf,
    /// Write the table here too.
    #[arg(long)]
    pub table: Option<PathBuf>,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum MotionScript {
    /// The camera circles the scene's centre, one degree per frame.
    Orbit,
    /// The first point or spot light swings along x.
    Light,
    /// The glTF animation `--animation` plays at 30 frames per second.
    Animation,
    /// `--object` (or the first point or spot light) slides a quarter of the scene's radius
    /// over frames F/4…F/2 and stops: also reports each run's lag and ghost after the stop.
    Slide,
}

#[derive(Args)]
pub struct MotionArgs {
    pub scene: PathBuf,
    /// What moves.
    #[arg(long, value_enum, default_value = "animation")]
    pub script: MotionScript,
    /// The glTF animation of `--script animation`.
    #[arg(long, default_value_t = 0)]
    pub animation: usize,
    /// The glTF node that `--script slide` moves (default: the first point or spot light).
    #[arg(long)]
    pub object: Option<String>,
    /// Frames rendered (one `PhotonMapping` frame each).
    #[arg(long, default_value_t = 48, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    pub frames: u32,
    /// Error measured every this many frames.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    pub every: u32,
    #[arg(long, default_value_t = 160)]
    pub width: u32,
    #[arg(long, default_value_t = 120)]
    pub height: u32,
    /// Photons per iteration.
    #[arg(long, default_value_t = 65_536)]
    pub photons: u32,
    /// Iterations per frame.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub iterations_per_frame: u32,
    /// `Reuse`'s history window (iterations).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub window: u32,
    /// Initial gather radius in pixels (default: the settings' own, which follows the view's
    /// size and the photon count).
    #[arg(long, value_parser = positive_number)]
    pub radius: Option<f32>,
    /// The runs' random numbers (`PhotonMapping::seed`; the references draw the next seed's).
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// Iterations of each converged frozen frame.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..))]
    pub reference_iterations: u32,
    /// Where motion.csv and motion.png go.
    #[arg(long, default_value = "out/motion")]
    pub out: PathBuf,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum Preset {
    Preview,
    Balanced,
    Reference,
}

/// `RppmTracer`'s choices.
#[derive(Clone, Copy, ValueEnum)]
pub enum Tracer {
    Auto,
    DeepCubemap,
    Bvh,
}

impl From<Tracer> for RppmTracer {
    fn from(t: Tracer) -> Self {
        match t {
            Tracer::Auto => RppmTracer::Auto,
            Tracer::DeepCubemap => RppmTracer::DeepCubemap,
            Tracer::Bvh => RppmTracer::Bvh,
        }
    }
}

#[derive(Clone, Copy, ValueEnum)]
pub enum DebugView {
    GbufferNormals,
    CubemapNormals,
    DirectPhotons,
}

#[derive(Args)]
pub struct RenderArgs {
    /// The glTF (or GLB) scene; its first camera is used, or a default one.
    pub scene: PathBuf,
    /// Let the scene's buffer and image URIs name files outside its folder.
    #[arg(long)]
    pub allow_outside_files: bool,
    /// Image width in pixels (1..=16384).
    #[arg(long, default_value_t = 512)]
    pub width: u32,
    /// Image height in pixels (1..=16384).
    #[arg(long, default_value_t = 512)]
    pub height: u32,
    /// Stop after this many iterations (default 16).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..), conflicts_with = "time_budget")]
    pub iterations: Option<u32>,
    /// Stop after this many seconds of rendering (from the first iteration).
    #[arg(long, value_parser = positive_seconds)]
    pub time_budget: Option<f64>,
    /// Write the image here (.exr: raw radiance; .png: preview); repeatable.
    #[arg(long, value_parser = image_path)]
    pub out: Vec<PathBuf>,
    /// Write the stats JSON here.
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Start from a measured preset; the flags below override it.
    #[arg(long, value_enum)]
    pub preset: Option<Preset>,
    /// Photons per iteration, fixed (default: as many as keep the photon stages at about the
    /// GPU time of the rest of an iteration, up to 262 144).
    #[arg(long)]
    pub photons: Option<u32>,
    /// Photons follow a GPU time per iteration instead: as many as keep an iteration near
    /// this many milliseconds (at most `--photons`, else 262 144).
    #[arg(long, value_parser = positive_number)]
    pub iteration_ms: Option<f32>,
    #[command(flatten)]
    pub frame: FrameArgs,
    /// Bounces a photon may take.
    #[arg(long)]
    pub photon_depth: Option<u32>,
    /// Bounces a camera path may take (1: the G-buffer only).
    #[arg(long)]
    pub eye_depth: Option<u32>,
    /// Initial gather radius in pixels (default: 6 in a 256² view of 262 144 photons,
    /// following the view's size and the photon count: `InitialRadius::PhotonShare`).
    #[arg(long, value_parser = positive_number)]
    pub radius: Option<f32>,
    /// Knaus–Zwicker α.
    #[arg(long, value_parser = finite_number)]
    pub alpha: Option<f32>,
    /// Deep-cubemap face resolution.
    #[arg(long)]
    pub cubemap: Option<u32>,
    /// Depth bins per cubemap tile.
    #[arg(long)]
    pub bins: Option<u32>,
    /// Cubemap tile size in pixels (1, 2 or 4).
    #[arg(long)]
    pub tile: Option<u32>,
    /// Gather-kernel thickness along the normal, over its radius.
    #[arg(long, value_parser = finite_number)]
    pub flattening: Option<f32>,
    /// Keep the global gather radius at every pixel (no kernel shrinks where it blurs).
    #[arg(long)]
    pub global_radius: bool,
    /// Splat photons on every n-th pixel (1, 2 or 4).
    #[arg(long)]
    pub subsampling: Option<u32>,
    /// Russian roulette on splat fragments.
    #[arg(long)]
    pub splat_rr: bool,
    /// A debug image instead of the estimate.
    #[arg(long, value_enum)]
    pub debug_view: Option<DebugView>,
    /// Submit and wait for each stage alone, reporting its CPU wall time per iteration
    /// (`wall_ms_per_iteration` in the stats; slow).
    #[arg(long)]
    pub profile: bool,
    /// Which random numbers the render draws (`PhotonMapping::seed`): renders with different
    /// seeds are independent.
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// What traces the rays (default: auto, today the BVH; the deep cubemap where the
    /// hierarchy is too big for the device).
    #[arg(long, value_enum, default_value_t = Tracer::Auto)]
    pub tracer: Tracer,
    /// Pose the scene by its glTF animation of this index (skins, morph weights, nodes).
    #[arg(long)]
    pub animation: Option<usize>,
    /// The instant of `--animation` to pose and hold, in seconds (wraps around the clip).
    #[arg(long, default_value_t = 0.0, requires = "animation", value_parser = non_negative_number)]
    pub animation_time: f32,
}

#[derive(Args)]
pub struct DirtArgs {
    pub scene: PathBuf,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Rays compared with brute force.
    #[arg(long, default_value_t = 1 << 16, value_parser = clap::value_parser!(u32).range(1..=1 << 24))]
    pub rays: u32,
    /// Rays traced for the timing.
    #[arg(long, default_value_t = 1 << 20, value_parser = clap::value_parser!(u32).range(1..=1 << 26))]
    pub timing_rays: u32,
    /// Face resolutions to sweep (16..=4096).
    #[arg(long, value_delimiter = ',', default_values_t = [64u32, 128, 256, 512], value_parser = clap::value_parser!(u32).range(16..=4096))]
    pub resolutions: Vec<u32>,
    /// Depth bins to sweep (1..=64).
    #[arg(long, value_delimiter = ',', default_values_t = [4u32, 8, 16, 32], value_parser = clap::value_parser!(u32).range(1..=64))]
    pub bins: Vec<u32>,
    /// Tile size (1, 2 or 4).
    #[arg(long, default_value_t = 1, value_parser = tile_size)]
    pub tile: u32,
}

#[derive(Args)]
pub struct TradeArgs {
    pub scene: PathBuf,
    /// The reference image (EXR) at the size to render.
    #[arg(long)]
    pub reference: PathBuf,
    /// Seconds each setting renders.
    #[arg(long, default_value_t = 20.0, value_parser = positive_seconds)]
    pub budget: f64,
    /// Where the CSVs and plots go.
    #[arg(long, default_value = "out/trade")]
    pub out: PathBuf,
    /// Only these knobs (comma-separated; default all).
    #[arg(long, value_delimiter = ',')]
    pub knobs: Vec<String>,
    /// The base setting's photons per iteration.
    #[arg(long)]
    pub photons: Option<u32>,
}

pub fn positive_seconds(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(s) if s.is_finite() && s > 0.0 => Ok(s),
        _ => Err(format!("'{text}' is not a positive number of seconds")),
    }
}

fn finite_number(text: &str) -> Result<f32, String> {
    match text.parse::<f32>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(format!("'{text}' is not a finite number")),
    }
}

fn positive_number(text: &str) -> Result<f32, String> {
    match finite_number(text) {
        Ok(x) if x > 0.0 => Ok(x),
        _ => Err(format!("'{text}' is not a finite number above 0")),
    }
}

fn non_negative_number(text: &str) -> Result<f32, String> {
    match text.parse::<f32>() {
        Ok(s) if s.is_finite() && s >= 0.0 => Ok(s),
        _ => Err(format!("'{text}' is not a finite number ≥ 0")),
    }
}

/// How many iterations a frame runs, for `render` and `bench suite`.
#[derive(Args)]
pub struct FrameArgs {
    /// GPU milliseconds a frame's iterations may take together: on a fast GPU several
    /// iterations run a frame instead of each waiting on a frame's CPU work and read-back
    /// (a software adapter, whose iterations are slower, runs one). 0: one a frame.
    #[arg(long, default_value_t = 25.0, value_parser = non_negative_number)]
    pub frame_ms: f32,
}

impl FrameArgs {
    /// Iterations a frame fitted to `--frame-ms` of GPU time (up to the most a frame runs),
    /// or one (0).
    pub fn iterations_per_frame(&self) -> IterationsPerFrame {
        if self.frame_ms > 0.0 {
            IterationsPerFrame::GpuMilliseconds {
                milliseconds: self.frame_ms,
                max: IterationsPerFrame::MOST,
            }
        } else {
            IterationsPerFrame::Fixed(1)
        }
    }
}

fn tile_size(text: &str) -> Result<u32, String> {
    match text.parse::<u32>() {
        Ok(t @ (1 | 2 | 4)) => Ok(t),
        _ => Err(format!("'{text}': the tile size is 1, 2 or 4")),
    }
}

fn image_path(text: &str) -> Result<PathBuf, String> {
    let path = PathBuf::from(text);
    match extension(&path).as_deref() {
        Some("exr" | "png") => Ok(path),
        _ => Err(format!("'{text}': the file must end in .exr or .png")),
    }
}

pub fn extension(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
}

pub fn default_render() -> RenderArgs {
    let out = PathBuf::from("out");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/cornell_box.gltf");
    let Cli {
        command: Some(Command::Render(mut args)),
    } = Cli::parse_from(["rppm", "render", scene, "--width", "256", "--height", "256"])
    else {
        unreachable!("a render command parses as one");
    };
    args.iterations = Some(32);
    args.photons = Some(65_536);
    args.out = vec![out.join("cornell_box.exr"), out.join("cornell_box.png")];
    args.stats = Some(out.join("cornell_box.json"));
    args
}

impl RenderArgs {
    pub fn settings(&self) -> PhotonMapping {
        let mut s = match self.preset {
            None => PhotonMapping::default(),
            Some(Preset::Preview) => RppmPreset::Preview.into(),
            Some(Preset::Balanced) => RppmPreset::Balanced.into(),
            Some(Preset::Reference) => RppmPreset::Reference.into(),
        };
        let set = |field: &mut u32, value: Option<u32>| *field = value.unwrap_or(*field);
        s.photons_per_iteration = match (self.iteration_ms, self.photons) {
            (Some(milliseconds), max) => PhotonCount::GpuMilliseconds {
                milliseconds,
                max: max.unwrap_or(s.photons_per_iteration.max()),
            },
            (None, Some(n)) => PhotonCount::Fixed(n),
            (None, None) => s.photons_per_iteration,
        };
        set(&mut s.max_photon_depth, self.photon_depth);
        set(&mut s.max_eye_depth, self.eye_depth);
        set(&mut s.cubemap_resolution, self.cubemap);
        set(&mut s.bins, self.bins);
        set(&mut s.cubemap_tile_size, self.tile);
        set(&mut s.indirect_subsampling, self.subsampling);
        if let Some(pixels) = self.radius {
            s.initial_radius = InitialRadius::Pixels(pixels);
        }
        s.alpha = self.alpha.unwrap_or(s.alpha);
        s.kernel_flattening = self.flattening.unwrap_or(s.kernel_flattening);
        s.adaptive_kernel &= !self.global_radius;
        s.splat_russian_roulette |= self.splat_rr;
        s.profile_stages |= self.profile;
        s.seed = self.seed;
        s.tracer = self.tracer.into();
        s.iterations_per_frame = self.frame.iterations_per_frame();
        if let Some(view) = self.debug_view {
            s.debug_view = match view {
                DebugView::GbufferNormals => RppmDebugView::GBufferNormals,
                DebugView::CubemapNormals => RppmDebugView::CubemapNormals,
                DebugView::DirectPhotons => RppmDebugView::DirectPhotons,
            };
        }
        s
    }

    pub fn request(&self) -> RenderRequest {
        RenderRequest {
            scene: self.scene.clone(),
            width: self.width,
            height: self.height,
            budget: match (self.iterations, self.time_budget) {
                (_, Some(seconds)) => Budget::Seconds(seconds),
                (n, None) => Budget::Iterations(n.unwrap_or(16)),
            },
            settings: self.settings(),
        }
    }
}
