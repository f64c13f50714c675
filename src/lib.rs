//! # bevy_rppm
//!
//! Rasterisation-based progressive photon mapping for Bevy: global illumination and caustics
//! on any GPU, no ray-tracing hardware, fully dynamic scenes.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use bevy_rppm::{PhotonMapping, RppmPlugin};
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, RppmPlugin))
//!     .add_systems(Startup, |mut commands: Commands| {
//!         commands.spawn((Camera3d::default(), PhotonMapping::default()));
//!     })
//!     .run();
//! ```
//!
//! One module per stage of an iteration, in the paper's words, each with its WGSL under
//! `shaders/<stage>/`: [`scene`] extraction → [`cubemap`] (the deep cubemap) → [`shadows`]
//! (direct light) → [`gbuffer`] → [`importons`] (eye paths) → [`photons`] → [`splat`] →
//! [`indirect_splat`] → [`accumulate`] → [`output`]. [`settings`], [`ppm`] and [`bsdf`] (pure
//! maths), [`shaders`] and [`stats`] are leaves; [`view`] holds what every stage of a camera shares;
//! `graph` prepares each camera's state and records the iterations.

pub mod accumulate;
pub mod bsdf;
pub mod cubemap;
#[cfg(feature = "debug")]
pub mod debug;
pub mod gbuffer;
mod graph;
pub mod importons;
pub mod indirect_splat;
pub mod output;
pub mod photons;
pub mod ppm;
pub mod scene;
pub mod settings;
pub mod shaders;
pub mod shadows;
pub mod splat;
pub mod stats;
pub mod view;

use bevy::prelude::*;
use bevy::render::RenderApp;
use bevy::shader::Shader;

/// The README's code, compiled by `cargo test --doc`.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

pub use ppm::{next_radius2, radius2_after};
pub use scene::{RppmScene, RppmSky, SceneData};
pub use settings::{
    InitialRadius, IterationsPerFrame, PhotonCount, PhotonMapping, RppmDebugView, RppmFastForward,
    RppmHistory, RppmMode, RppmPreset, RppmReadback, RppmTracer, ViewEpoch,
};
pub use stats::{RadianceImage, RppmRadiance, RppmStats, ViewStats};

/// Adds photon mapping to every camera that has a [`PhotonMapping`] component.
pub struct RppmPlugin;

impl Plugin for RppmPlugin {
    fn build(&self, app: &mut App) {
        let Some(mut shader_assets) = app.world_mut().get_resource_mut::<Assets<Shader>>() else {
            error!(
                "bevy_rppm: RppmPlugin needs Bevy's render plugins; add it after DefaultPlugins"
            );
            return;
        };
        let shaders = shaders::RppmShaders::load(&mut shader_assets);
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app.insert_resource(shaders);
        }
        app.add_plugins((
            stats::StatsPlugin,
            scene::ScenePlugin,
            view::ViewPlugin,
            (
                shadows::ShadowsPlugin,
                gbuffer::GBufferPlugin,
                cubemap::CubemapPlugin,
                importons::ImportonsPlugin,
                photons::PhotonsPlugin,
                splat::SplatPlugin,
                indirect_splat::IndirectSplatPlugin,
                accumulate::AccumulatePlugin,
                output::OutputPlugin,
            ),
            graph::GraphPlugin,
        ));
        #[cfg(feature = "debug")]
        app.add_plugins(debug::DebugPlugin);
    }
}

#[cfg(test)]
mod tests {
    use std::collections::{BTreeMap, BTreeSet};
    use std::path::Path;

    /// Every file under `dir` whose extension is one of `extensions`: (path relative to
    /// `root`, text).
    fn sources(root: &Path, dir: &Path, extensions: &[&str], out: &mut Vec<(String, String)>) {
        for entry in std::fs::read_dir(dir).unwrap().flatten() {
            let path = entry.path();
            if path.is_dir() {
                sources(root, &path, extensions, out);
            } else if path
                .extension()
                .is_some_and(|e| extensions.iter().any(|x| e == *x))
            {
                let relative = path.strip_prefix(root).unwrap().display().to_string();
                out.push((relative, std::fs::read_to_string(&path).unwrap()));
            }
        }
    }

    /// The house rules: top-level modules depend on each other one way (no cycle among the
    /// `crate::` references), and no file is over 500 lines.
    #[test]
    fn modules_depend_one_way_and_files_stay_small() {
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
        let mut files = Vec::new();
        sources(&src, &src, &["rs"], &mut files);
        let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (path, text) in &files {
            assert!(
                text.lines().count() <= 500,
                "{path} has {} lines",
                text.lines().count()
            );
            let module = path.split(['/', '.']).next().unwrap().to_string();
            if module == "lib" {
                continue;
            }
            let uses = graph.entry(module.clone()).or_default();
            for part in text.split("crate::").skip(1) {
                let name: String = part
                    .chars()
                    .take_while(|c| c.is_ascii_lowercase() || *c == '_')
                    .collect();
                if !name.is_empty() && name != module {
                    uses.insert(name);
                }
            }
        }
        // Depth-first search for a back edge.
        fn visit(
            node: &str,
            graph: &BTreeMap<String, BTreeSet<String>>,
            path: &mut Vec<String>,
            done: &mut BTreeSet<String>,
        ) {
            if done.contains(node) {
                return;
            }
            assert!(!path.iter().any(|p| p == node), "cycle: {path:?} -> {node}");
            path.push(node.to_string());
            for next in graph.get(node).into_iter().flatten() {
                visit(next, graph, path, done);
            }
            path.pop();
            done.insert(node.to_string());
        }
        let mut done = BTreeSet::new();
        for node in graph.keys() {
            visit(node, &graph, &mut Vec::new(), &mut done);
        }
    }

    /// No file of ours is over 500 lines: the library, its shaders, the tool crate, the tests,
    /// the examples and the scripts (the library's own files are checked above too).
    #[test]
    fn no_source_file_is_over_500_lines() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut files = Vec::new();
        for dir in [
            "src",
            "shaders",
            "cli/src",
            "cli/tests",
            "tests",
            "examples",
            "tools",
        ] {
            sources(
                root,
                &root.join(dir),
                &["rs", "wgsl", "py", "sh"],
                &mut files,
            );
        }
        let long: Vec<String> = (files.iter())
            .filter(|(_, text)| text.lines().count() > 500)
            .map(|(path, text)| format!("{path} has {} lines", text.lines().count()))
            .collect();
        assert!(long.is_empty(), "{}", long.join("\n"));
    }

    /// llvmpipe compiles each inlined copy of a ray walk anew, for every shader variant a
    /// scene needs: with a walk per kind of light and per camera-path vertex, the
    /// local-illumination stage took 7.6 s to compile (16.8 s textured), with one 1.2 s
    /// (3.3 s). Its shader calls the walk, the lighting and the BSDF from one place each
    /// (and, under `Reuse` alone, `camera_hit` for a pixel's shading point).
    #[test]
    fn local_illumination_calls_each_ray_walk_from_one_place() {
        let shaders = Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
        let read = |p: &str| std::fs::read_to_string(shaders.join(p)).unwrap();
        // Calls of `f`: `f(` after no identifier character, and not its definition.
        let calls = |text: &str, f: &str| {
            text.match_indices(&format!("{f}("))
                .filter(|(i, _)| {
                    let before = text[..*i].chars().next_back();
                    !before.is_some_and(|c| c.is_alphanumeric() || c == '_')
                        && !text[..*i].ends_with("fn ")
                })
                .count()
        };
        let lighting = read("shadows/lighting.wgsl");
        let paths = read("importons/eye_paths.wgsl");
        let indirect = read("indirect_splat/indirect_splat.wgsl");
        for (text, f) in [
            (&lighting, "occluded"),
            (&lighting, "visibility"),
            (&paths, "surface_light"),
            (&paths, "trace_ray"),
            (&indirect, "gathered"),
        ] {
            assert_eq!(calls(text, f), 1, "calls of {f}");
        }
        // One with traced shadows and one for the emitter candidates (`resampled_emitter`, in
        // a loop), two with shadow maps (the punctual lights, the area light).
        assert_eq!(calls(&lighting, "bsdf_eval"), 4);
    }

    /// Layouts the shaders and the CPU share: each WGSL constant equals its Rust twin.
    #[test]
    fn shader_constants_mirror_the_cpu_side() {
        let shaders = Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
        // The value of `const NAME: TYPE = VALUE;` in a shader, as written (no `u` suffix).
        let constant = |file: &str, name: &str, ty: &str| -> String {
            let text = std::fs::read_to_string(shaders.join(file)).unwrap();
            let line = text
                .lines()
                .find(|l| l.starts_with(&format!("const {name}: {ty} = ")))
                .unwrap_or_else(|| panic!("{name} in {file}"));
            let value = line.rsplit(' ').next().unwrap();
            value.trim_end_matches(['u', ';']).to_string()
        };
        let value =
            |file: &str, name: &str| -> usize { constant(file, name, "u32").parse().unwrap() };
        let float =
            |file: &str, name: &str| -> f32 { constant(file, name, "f32").parse().unwrap() };
        use crate::scene::upload::{MATERIAL_TEXELS, MATERIALS_ROW};
        assert_eq!(
            value("scene/scene.wgsl", "MATERIAL_TEXELS"),
            MATERIAL_TEXELS
        );
        assert_eq!(value("scene/scene.wgsl", "MATERIALS_ROW"), MATERIALS_ROW);
        assert_eq!(
            value("common/microfacet.wgsl", "ALBEDO_SIZE"),
            crate::bsdf::SIZE
        );
        assert_eq!(
            value("photons/sort.wgsl", "SCAN_BLOCK"),
            crate::photons::SCAN_BLOCK as usize
        );
        // The gathers' rows and their tested mirror (src/photons/ellipse.rs).
        use crate::photons::ellipse::{DISC_SHARE, MARGIN};
        assert_eq!(float("photons/map.wgsl", "MARGIN"), MARGIN);
        assert_eq!(float("photons/map.wgsl", "DISC_SHARE"), DISC_SHARE);
        // An importon's disc and its tested mirror (src/indirect_splat/disc.rs).
        use crate::indirect_splat::disc::{DISC_POINTS, GRAZING_COS, SHARE_POINTS};
        let splat = "indirect_splat/indirect_splat.wgsl";
        assert_eq!(value(splat, "DISC_POINTS"), DISC_POINTS as usize);
        assert_eq!(value(splat, "SHARE_POINTS"), SHARE_POINTS as usize);
        assert_eq!(float(splat, "GRAZING_COS"), GRAZING_COS);
        // Which surfaces are mirrors and which store photons (camera paths go on through the rest).
        use crate::bsdf::{DELTA_ROUGHNESS, GLOSSY_STORE_ROUGHNESS};
        assert_eq!(
            float("common/common.wgsl", "DELTA_ROUGHNESS"),
            DELTA_ROUGHNESS
        );
        assert_eq!(
            float("common/bsdf.wgsl", "GLOSSY_STORE_ROUGHNESS"),
            GLOSSY_STORE_ROUGHNESS
        );
    }
}
