//! `rppm bench suite`: every scene with a Mitsuba 3 reference beside it (`NAME.gltf` and
//! `NAME.ref.exr`), rendered for the same wall-clock budget by us (default settings) and by
//! Mitsuba 3's path tracer (`tools/reference.py`, its spp chosen to take the budget), each
//! scored against the reference.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result, bail};
use bevy_rppm::PhotonMapping;
use serde::{Deserialize, Serialize};

use crate::headless::{Budget, RenderRequest, render_gltf};
use crate::image_io::{
    RgbImage, bad_pixels, energy_ratio, read_exr, relative_error, relmse, same_size,
};

/// A scene and its reference.
#[derive(Clone, Debug)]
pub struct SuiteScene {
    pub name: String,
    pub scene: PathBuf,
    pub reference: PathBuf,
    /// The reference's samples per pixel, from the `NAME.ref.json` beside it
    /// (`tools/reference.py --json`), where there is one.
    pub reference_spp: Option<u32>,
}

#[derive(Deserialize)]
struct ReferenceRun {
    spp: u32,
}

/// The spp a reference's JSON gives, if it is there and says.
fn reference_spp(json: &Path) -> Option<u32> {
    let text = std::fs::read_to_string(json).ok()?;
    serde_json::from_str::<ReferenceRun>(&text)
        .ok()
        .map(|r| r.spp)
}

/// A path tracer's score against a reference of fewer than this many times its samples is
/// mostly the reference's own noise.
const REFERENCE_MARGIN: u32 = 4;

/// Every `NAME.gltf` in `dirs` with a `NAME.ref.exr` beside it, by name.
pub fn find_scenes(dirs: &[PathBuf]) -> Result<Vec<SuiteScene>> {
    let mut scenes = Vec::new();
    for dir in dirs {
        let entries = std::fs::read_dir(dir).with_context(|| format!("{}", dir.display()))?;
        for entry in entries {
            let scene = entry?.path();
            let Some(name) = scene
                .file_name()
                .and_then(|n| n.to_str())
                .and_then(|n| n.strip_suffix(".gltf"))
            else {
                continue;
            };
            let reference = dir.join(format!("{name}.ref.exr"));
            if reference.exists() {
                let reference_spp = reference_spp(&dir.join(format!("{name}.ref.json")));
                scenes.push(SuiteScene {
                    name: name.to_string(),
                    scene,
                    reference,
                    reference_spp,
                });
            }
        }
    }
    scenes.sort_by(|a, b| a.name.cmp(&b.name));
    if scenes.is_empty() {
        bail!("no NAME.gltf with a NAME.ref.exr beside it in {dirs:?}");
    }
    Ok(scenes)
}

/// Error and energy of an image against its reference (`rppm compare` prints it as JSON).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Score {
    pub relmse: f64,
    pub energy_ratio: f64,
    pub bad_pixels: usize,
}

impl Score {
    pub fn of(image: &RgbImage, reference: &RgbImage) -> Result<Self> {
        Ok(Self {
            relmse: relmse(image, reference).map_err(anyhow::Error::msg)?,
            energy_ratio: energy_ratio(image, reference).map_err(anyhow::Error::msg)?,
            bad_pixels: bad_pixels(image),
        })
    }
}

/// Prints the metrics of shared/docs/CONVENTIONS.md for a test image against a reference.
pub fn compare(test: &Path, reference: &Path, blocks: Option<u32>) -> Result<()> {
    let (test, reference) = (
        read_exr(test).map_err(anyhow::Error::msg)?,
        read_exr(reference).map_err(anyhow::Error::msg)?,
    );
    let score = Score::of(&test, &reference)?;
    println!("{}", serde_json::to_string(&score)?);
    if let Some(n) = blocks {
        let blocks = Blocks::of(&test, &reference, n as usize)?;
        println!("{}", serde_json::to_string(&blocks)?);
    }
    Ok(())
}

/// Where the error and the energy of an image lie (`rppm compare --blocks N`): the image cut
/// into N × N blocks, row by row from the top.
#[derive(Clone, Debug, Serialize)]
pub struct Blocks {
    /// Each block's share of the image's summed relative squared error (0..1, summing to 1).
    pub error_share: Vec<Vec<f64>>,
    /// Each block's energy ratio, mean(t) / mean(r).
    pub energy: Vec<Vec<f64>>,
}

impl Blocks {
    pub fn of(image: &RgbImage, reference: &RgbImage, n: usize) -> Result<Self> {
        same_size(image, reference).map_err(anyhow::Error::msg)?;
        let (w, h) = (reference.width, reference.height);
        if n == 0 || n > w.min(h) {
            bail!("{n} blocks a side do not fit a {w}x{h} image");
        }
        let mut sums = vec![vec![[0.0f64; 3]; n]; n]; // error, test, reference
        for (i, (t, r)) in image.pixels.iter().zip(&reference.pixels).enumerate() {
            let cell = &mut sums[(i / w) * n / h][(i % w) * n / w];
            for (t, r) in t.iter().zip(r).map(|(&t, &r)| (t as f64, r as f64)) {
                cell[0] += relative_error(t, r);
                cell[1] += t;
                cell[2] += r;
            }
        }
        let total: f64 = sums.iter().flatten().map(|c| c[0]).sum();
        let map = |f: &dyn Fn(&[f64; 3]) -> f64| {
            sums.iter().map(|row| row.iter().map(f).collect()).collect()
        };
        Ok(Self {
            error_share: map(&|c| if total > 0.0 { c[0] / total } else { 0.0 }),
            energy: map(&|c| if c[2] > 0.0 { c[1] / c[2] } else { 0.0 }),
        })
    }
}

/// One scene's row of the table.
#[derive(Clone, Debug)]
pub struct SuiteRow {
    pub name: String,
    pub width: u32,
    pub height: u32,
    pub ours: Score,
    pub iterations: u32,
    /// Photons per iteration at the end (the automatic count's choice).
    pub photons: u32,
    /// Mitsuba's path tracer at the same wall time: spp, seconds and score.
    pub path: Option<(u32, f64, Score)>,
    /// The reference's spp, where known.
    pub reference_spp: Option<u32>,
}

/// Renders `scene` for `seconds` with `settings` at its reference's size, and with Mitsuba's
/// path tracer for as long when `mitsuba` is given (the path of `tools/reference.py`).
pub fn run_scene(
    scene: &SuiteScene,
    settings: &PhotonMapping,
    seconds: f64,
    mitsuba: Option<(&Path, &str)>,
    scratch: &Path,
) -> Result<SuiteRow> {
    let reference = read_exr(&scene.reference).map_err(anyhow::Error::msg)?;
    let request = RenderRequest {
        scene: scene.scene.clone(),
        width: reference.width as u32,
        height: reference.height as u32,
        budget: Budget::Seconds(seconds),
        settings: settings.clone(),
    };
    let ours = render_gltf(&request, |_| {}).map_err(anyhow::Error::msg)?;
    // A failed Mitsuba run leaves its cells empty rather than the whole table unwritten.
    let path = mitsuba.and_then(|(tool, variant)| {
        path_tracer(tool, scene, &reference, seconds, variant, scratch)
            .map_err(|e| eprintln!("rppm: {}: Mitsuba failed: {e:#}", scene.name))
            .ok()
    });
    Ok(SuiteRow {
        name: scene.name.clone(),
        width: reference.width as u32,
        height: reference.height as u32,
        ours: Score::of(&ours.image, &reference)?,
        iterations: ours.iterations,
        photons: ours.stats.photons_per_iteration,
        path,
        reference_spp: scene.reference_spp,
    })
}

#[derive(Deserialize)]
struct MitsubaRun {
    time_render_s: f64,
}

/// Mitsuba 3's path tracer on `scene` for about `seconds` of render time: a short run times
/// a sample per pixel, then the budget's spp run is scored.
fn path_tracer(
    tool: &Path,
    scene: &SuiteScene,
    reference: &RgbImage,
    seconds: f64,
    variant: &str,
    scratch: &Path,
) -> Result<(u32, f64, Score)> {
    std::fs::create_dir_all(scratch)?;
    let exr = scratch.join(format!("{}.path.exr", scene.name));
    let json = scratch.join(format!("{}.path.json", scene.name));
    let run = |spp: u32| -> Result<f64> {
        let status = Command::new("python3")
            .arg(tool)
            .arg(&scene.scene)
            .args([
                "--out".as_ref(),
                exr.as_os_str(),
                "--json".as_ref(),
                json.as_os_str(),
            ])
            .args(["--width", &reference.width.to_string()])
            .args(["--height", &reference.height.to_string()])
            .args([
                "--spp",
                &spp.to_string(),
                "--seed",
                "7",
                "--variant",
                variant,
            ])
            .output()
            .context("running python3 (Mitsuba 3: pip install mitsuba numpy)")?;
        if !status.status.success() {
            bail!(
                "{} failed: {}",
                tool.display(),
                String::from_utf8_lossy(&status.stderr).trim()
            );
        }
        let text = std::fs::read_to_string(&json)?;
        let run: MitsubaRun = serde_json::from_str(&text)?;
        Ok(run.time_render_s)
    };
    // The first run also compiles Mitsuba's kernels: time a second one.
    run(4)?;
    // A probe too short to time (a GPU's 16 spp) is run again, longer.
    let mut probe = 16;
    let mut probe_s = run(probe)?;
    if probe_s < 0.2 {
        probe = (f64::from(probe) * (0.5 / probe_s.max(1e-4))).min(65536.0) as u32;
        probe_s = run(probe)?;
    }
    let per_spp = probe_s.max(1e-4) / f64::from(probe);
    let mut spp = ((seconds / per_spp) as u32).max(1);
    let mut took = run(spp)?;
    // Time is not linear in spp where a fixed cost dominates the probe (on a GPU the budget's
    // run took a quarter of it): scale to the time taken until within 20 % of the budget.
    for _ in 0..2 {
        if took >= 0.8 * seconds {
            break;
        }
        spp = (f64::from(spp) * seconds / took.max(1e-3)).min(1e7) as u32;
        took = run(spp)?;
    }
    let image = read_exr(&exr).map_err(anyhow::Error::msg)?;
    Ok((spp, took, Score::of(&image, reference)?))
}

/// An error with three significant digits and at least four decimals (0.0160, 0.000412):
/// a GPU's renders come within 10⁻⁴ of each other and of the references' own noise.
pub fn three_digits(x: f64) -> String {
    let decimals = if x > 0.0 && x.is_finite() {
        (2 - x.log10().floor() as i32).clamp(4, 12) as usize
    } else {
        4
    };
    format!("{x:.decimals$}")
}

/// The table, in Markdown. A path tracer's score against a reference of fewer than
/// `REFERENCE_MARGIN` times its spp is marked †, and one against a reference of unknown spp ?:
/// the reference's own noise may be most of it.
pub fn table(rows: &[SuiteRow], seconds: f64) -> String {
    let mut out = format!(
        "| scene | size | iterations | photons / it. | relMSE | energy | bad px | ref. spp | path spp ({seconds} s) | path s | path relMSE | path / ours |\n\
         |---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n"
    );
    let mut marks = (false, false);
    for r in rows {
        let (spp, took, path, ratio) = match r.path {
            Some((spp, took, s)) => {
                let mark = match r.reference_spp {
                    Some(reference) if reference < REFERENCE_MARGIN.saturating_mul(spp) => {
                        marks.0 = true;
                        " †"
                    }
                    Some(_) => "",
                    None => {
                        marks.1 = true;
                        " ?"
                    }
                };
                (
                    spp.to_string(),
                    format!("{took:.1}"),
                    format!("{}{mark}", three_digits(s.relmse)),
                    format!("{:.2}", s.relmse / r.ours.relmse.max(1e-12)),
                )
            }
            None => ("–".into(), "–".into(), "–".into(), "–".into()),
        };
        let reference = r.reference_spp.map_or("–".into(), |s| s.to_string());
        out += &format!(
            "| {} | {}×{} | {} | {} | {} | {:.3} | {} | {reference} | {spp} | {took} | {path} | {ratio} |\n",
            r.name,
            r.width,
            r.height,
            r.iterations,
            r.photons,
            three_digits(r.ours.relmse),
            r.ours.energy_ratio,
            r.ours.bad_pixels
        );
    }
    if marks.0 {
        out += &format!(
            "\n† The reference holds fewer than {REFERENCE_MARGIN}× the path tracer's spp: its own noise is much of that score.\n"
        );
    }
    if marks.1 {
        out += "\n? The reference's spp is unknown (no `NAME.ref.json` beside it): its own noise may be much of that score.\n";
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_find_where_the_error_lies() {
        let reference = RgbImage {
            width: 4,
            height: 4,
            pixels: vec![[1.0; 3]; 16],
        };
        let mut image = reference.clone();
        image.pixels[4 + 3] = [3.0; 3]; // second row, last column: block (0, 1) of 2 × 2
        let blocks = Blocks::of(&image, &reference, 2).unwrap();
        assert_eq!(blocks.error_share[0][1], 1.0);
        assert_eq!(blocks.error_share[1][0], 0.0);
        assert_eq!(blocks.energy[0][1], 1.5);
        assert_eq!(blocks.energy[1][1], 1.0);
        assert!(Blocks::of(&image, &reference, 5).is_err());
    }

    #[test]
    fn a_path_tracer_scored_against_a_noisier_reference_is_marked() {
        let score = Score {
            relmse: 0.001,
            energy_ratio: 1.0,
            bad_pixels: 0,
        };
        let row = |name: &str, reference_spp| SuiteRow {
            name: name.into(),
            width: 128,
            height: 128,
            ours: score,
            iterations: 60,
            photons: 1 << 18,
            path: Some((4000, 60.0, score)),
            reference_spp,
        };
        let rows = [row("deep", Some(32768)), row("shallow", Some(2048))];
        let text = table(&rows, 60.0);
        let line = |name: &str| {
            text.lines()
                .find(|l| l.starts_with(&format!("| {name} ")))
                .unwrap()
        };
        assert!(!line("deep").contains('†') && line("deep").contains("| 32768 |"));
        assert!(line("shallow").contains("0.00100 †"));
        assert!(text.contains("† The reference holds fewer") && !text.contains("? The"));
        assert!(table(&[row("unknown", None)], 60.0).contains("0.00100 ?"));
    }

    #[test]
    fn errors_keep_three_digits() {
        assert_eq!(three_digits(0.016), "0.0160");
        assert_eq!(three_digits(0.000412), "0.000412");
        assert_eq!(three_digits(1.49), "1.4900");
        assert_eq!(three_digits(0.0), "0.0000");
        assert_eq!(three_digits(f64::NAN), "NaN");
    }
}
