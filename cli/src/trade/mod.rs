//! `rppm bench trade`: the speed/accuracy trade of every knob, measured. From a base setting,
//! each knob is swept on its own; every run renders for a wall-clock budget and records the
//! relMSE against a reference after each iteration, with GPU ms per stage and memory held.

pub mod plot;

use std::path::{Path, PathBuf};

use bevy_rppm::stats::timing::Stage;
use bevy_rppm::{InitialRadius, PhotonCount, PhotonMapping, RppmMode, ViewStats};

use crate::headless::{Budget, RenderRequest, render_gltf};
use crate::image_io::{RgbImage, relmse};

/// One knob and the values it is swept over (each a full setting: the base with that knob
/// changed).
pub struct Knob {
    pub name: &'static str,
    pub values: Vec<(String, PhotonMapping)>,
}

fn sweep<T: std::fmt::Display + Copy>(
    base: &PhotonMapping,
    name: &'static str,
    values: &[T],
    set: impl Fn(&mut PhotonMapping, T),
) -> Knob {
    let values = values
        .iter()
        .map(|&v| {
            let mut settings = base.clone();
            set(&mut settings, v);
            (v.to_string(), settings)
        })
        .collect();
    Knob { name, values }
}

/// Every knob of [`PhotonMapping`] that trades speed for accuracy, around `base`.
pub fn knobs(base: &PhotonMapping) -> Vec<Knob> {
    vec![
        sweep(base, "photons", &[16_384u32, 65_536, 262_144], |s, v| {
            s.photons_per_iteration = PhotonCount::Fixed(v)
        }),
        sweep(base, "cubemap", &[128u32, 256, 512], |s, v| {
            s.cubemap_resolution = v
        }),
        sweep(base, "bins", &[4u32, 12, 32], |s, v| s.bins = v),
        sweep(base, "tile", &[1u32, 2, 4], |s, v| s.cubemap_tile_size = v),
        sweep(base, "alpha", &[0.5f32, 0.7, 0.9], |s, v| s.alpha = v),
        sweep(base, "radius", &[2.0f32, 4.0, 8.0], |s, v| {
            s.initial_radius = InitialRadius::Pixels(v)
        }),
        sweep(base, "splat_rr", &[false, true], |s, v| {
            s.splat_russian_roulette = v
        }),
        sweep(base, "photon_depth", &[3u32, 8, 16], |s, v| {
            s.max_photon_depth = v
        }),
        sweep(base, "eye_depth", &[1u32, 3, 6], |s, v| s.max_eye_depth = v),
        sweep(base, "mode", &["full", "indirect"], |s, v| {
            s.mode = if v == "full" {
                RppmMode::Full
            } else {
                RppmMode::Indirect
            }
        }),
        sweep(base, "flattening", &[0.03f32, 0.1, 0.3, 1.0], |s, v| {
            s.kernel_flattening = v
        }),
        sweep(base, "subsampling", &[1u32, 2, 4], |s, v| {
            s.indirect_subsampling = v
        }),
    ]
}

/// The estimate's error after one iteration.
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    pub iteration: u32,
    /// Wall-clock seconds since the frame that rendered the first iteration.
    pub seconds: f64,
    /// Against the reference; NaN where the estimate is not comparable (mode Indirect leaves
    /// the first hit's direct light to Bevy).
    pub relmse: f64,
}

/// One setting rendered for the budget.
#[derive(Clone, Debug)]
pub struct Run {
    pub knob: String,
    pub value: String,
    pub settings: PhotonMapping,
    pub samples: Vec<Sample>,
    pub stats: ViewStats,
    pub error: Option<String>,
}

impl Run {
    /// The last sample within `seconds`.
    pub fn at(&self, seconds: f64) -> Option<Sample> {
        self.samples
            .iter()
            .take_while(|s| s.seconds <= seconds)
            .last()
            .copied()
    }

    pub fn comparable(&self) -> bool {
        comparable_mode(&self.settings)
            && self.error.is_none()
            && self.samples.iter().any(|s| s.relmse.is_finite())
    }

    /// Mean GPU milliseconds per iteration of each stage.
    pub fn gpu_ms(&self) -> Vec<(String, f64)> {
        let n = self.stats.timed_iterations.max(1) as f64;
        let ms = &self.stats.stage_ms_total;
        ms.iter().map(|(k, v)| (k.clone(), v / n)).collect()
    }
}

pub struct TradeRequest {
    pub scene: PathBuf,
    pub reference: RgbImage,
    pub budget_seconds: f64,
    pub base: PhotonMapping,
    /// Knobs to sweep (all when empty).
    pub only: Vec<String>,
}

/// Renders every knob's values for the budget. A setting equal to one already rendered (each
/// knob's base value) is rendered once and shared.
pub fn run_trade(request: &TradeRequest, mut log: impl FnMut(&str)) -> Vec<Run> {
    let mut runs: Vec<Run> = Vec::new();
    for knob in knobs(&request.base) {
        if !request.only.is_empty() && !request.only.iter().any(|k| k == knob.name) {
            continue;
        }
        for (value, settings) in knob.values {
            if let Some(done) = runs.iter().find(|r| r.settings == settings) {
                let shared = Run {
                    knob: knob.name.to_string(),
                    value,
                    ..done.clone()
                };
                runs.push(shared);
                continue;
            }
            let run = render_run(request, knob.name, value, settings);
            let last = run.samples.last();
            log(&format!(
                "{:<13} {:<9} {:>5} iterations  relMSE {:.5}{}",
                run.knob,
                run.value,
                last.map_or(0, |s| s.iteration),
                last.map_or(f64::NAN, |s| s.relmse),
                run.error
                    .as_deref()
                    .map(|e| format!("  error: {e}"))
                    .unwrap_or_default()
            ));
            runs.push(run);
        }
    }
    runs
}

fn render_run(request: &TradeRequest, knob: &str, value: String, settings: PhotonMapping) -> Run {
    let reference = &request.reference;
    let render = RenderRequest {
        scene: request.scene.clone(),
        width: reference.width as u32,
        height: reference.height as u32,
        budget: Budget::Seconds(request.budget_seconds),
        settings: settings.clone(),
    };
    let comparable = comparable_mode(&settings);
    let mut samples = Vec::new();
    let result = render_gltf(&render, |p| {
        let image = RgbImage::from_rgba(p.image.width, p.image.height, &p.image.pixels);
        let error = if comparable {
            relmse(&image, reference).unwrap_or(f64::NAN)
        } else {
            f64::NAN
        };
        samples.push(Sample {
            iteration: p.iteration,
            seconds: p.seconds,
            relmse: error,
        });
    });
    let (stats, error) = match result {
        Ok(r) => (r.stats, None),
        Err(e) => (ViewStats::default(), Some(e)),
    };
    Run {
        knob: knob.to_string(),
        value,
        settings,
        samples,
        stats,
        error,
    }
}

/// Whether the estimate holds the whole image (mode Indirect leaves first-hit direct light to
/// Bevy, so it cannot be compared with a reference).
fn comparable_mode(settings: &PhotonMapping) -> bool {
    settings.mode == RppmMode::Full
}

/// The lower envelope of (seconds, relMSE) over every comparable run: for each time, the
/// least error any setting had reached by then.
pub fn pareto_front(runs: &[Run]) -> Vec<(f64, f64)> {
    let mut points: Vec<(f64, f64)> = runs
        .iter()
        .filter(|r| r.comparable())
        .flat_map(|r| r.samples.iter().map(|s| (s.seconds, s.relmse)))
        .filter(|(t, e)| *t > 0.0 && e.is_finite())
        .collect();
    points.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut front: Vec<(f64, f64)> = Vec::new();
    for p in points {
        if front.last().is_none_or(|last| p.1 < last.1) {
            front.push(p);
        }
    }
    front
}

/// The comparable run with the least error within `seconds`.
pub fn best_at(runs: &[Run], seconds: f64) -> Option<(&Run, Sample)> {
    runs.iter()
        .filter(|r| r.comparable())
        .filter_map(|r| r.at(seconds).map(|s| (r, s)))
        .filter(|(_, s)| s.relmse.is_finite())
        .min_by(|a, b| a.1.relmse.total_cmp(&b.1.relmse))
}

/// Blank where there is no number (NaN), so that CSV readers see a missing value.
fn optional(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.6e}")
    } else {
        String::new()
    }
}

/// `samples.csv` (one row per iteration of every run) and `runs.csv` (one row per run: final
/// error, GPU ms per stage, memory).
pub fn write_csv(runs: &[Run], dir: &Path) -> anyhow::Result<()> {
    let mut samples = csv::Writer::from_path(dir.join("samples.csv"))?;
    samples.write_record(["knob", "value", "iteration", "seconds", "relmse"])?;
    for run in runs {
        for s in &run.samples {
            samples.write_record([
                run.knob.to_string(),
                run.value.clone(),
                s.iteration.to_string(),
                format!("{:.3}", s.seconds),
                optional(s.relmse),
            ])?;
        }
    }
    samples.flush()?;
    let stages: Vec<&str> = Stage::ALL.iter().map(|s| s.name()).collect();
    let mut table = csv::Writer::from_path(dir.join("runs.csv"))?;
    let mut header: Vec<String> = [
        "knob",
        "value",
        "iterations",
        "seconds",
        "relmse",
        "memory_mib",
    ]
    .map(String::from)
    .to_vec();
    header.extend(stages.iter().map(|s| format!("gpu_ms_{s}")));
    header.push("error".into());
    table.write_record(&header)?;
    for run in runs {
        let last = run.samples.last();
        let memory: u64 = run.stats.memory.values().sum();
        let ms = run.gpu_ms();
        let mut row = vec![
            run.knob.to_string(),
            run.value.clone(),
            last.map_or(0, |s| s.iteration).to_string(),
            format!("{:.3}", last.map_or(0.0, |s| s.seconds)),
            optional(last.map_or(f64::NAN, |s| s.relmse)),
            format!("{:.1}", memory as f64 / (1u64 << 20) as f64),
        ];
        row.extend(stages.iter().map(|s| {
            let v = ms.iter().find(|(k, _)| k == s).map_or(0.0, |(_, v)| *v);
            format!("{v:.3}")
        }));
        row.push(run.error.clone().unwrap_or_default());
        table.write_record(&row)?;
    }
    table.flush()?;
    Ok(())
}

/// Reads back what [`write_csv`] wrote (the runs' knobs, values, samples and errors; not their
/// settings or GPU times), to draw the plots again without rendering.
pub fn read_csv(dir: &Path) -> anyhow::Result<Vec<Run>> {
    #[derive(serde::Deserialize)]
    struct Row {
        knob: String,
        value: String,
        iteration: u32,
        seconds: f64,
        relmse: Option<f64>,
    }
    let mut runs: Vec<Run> = Vec::new();
    let path = dir.join("samples.csv");
    let mut reader = csv::Reader::from_path(&path)
        .map_err(|e| anyhow::anyhow!("cannot read {}: {e}", path.display()))?;
    for row in reader.deserialize() {
        let row: Row = row?;
        let sample = Sample {
            iteration: row.iteration,
            seconds: row.seconds,
            relmse: row.relmse.unwrap_or(f64::NAN),
        };
        match runs
            .iter_mut()
            .find(|r| r.knob == row.knob && r.value == row.value)
        {
            Some(run) => run.samples.push(sample),
            None => runs.push(Run {
                knob: row.knob,
                value: row.value,
                settings: PhotonMapping::default(),
                samples: vec![sample],
                stats: ViewStats::default(),
                error: None,
            }),
        }
    }
    Ok(runs)
}
