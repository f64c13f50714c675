//! Flags at their extremes, and the other commands' inputs.

use super::{error, json_bytes, render};
use crate::catalogue::scene::base;
use crate::catalogue::{Case, Expect};

/// Flags at their extremes, and the other commands' inputs.
pub fn flags() -> Vec<Case> {
    let g = "flags";
    let scene = || vec![("scene.gltf".to_string(), json_bytes(&base()))];
    let with = |name: &str, extra: &[&str], expect: Expect| {
        let mut args = render("scene.gltf");
        // A flag given twice is refused by clap: drop the base's values of the same flags.
        for flag in extra.iter().filter(|f| f.starts_with("--")) {
            if let Some(i) = args.iter().position(|a| a == flag) {
                args.drain(i..i + 2);
            }
        }
        args.extend(extra.iter().map(|s| s.to_string()));
        Case::new(name, g, scene(), args, expect)
    };
    let clap = || error("see rppm --help");
    let mut cases = vec![
        with("--width 0", &["--width", "0"], error("outside 1..=16384")),
        with(
            "--width 16385",
            &["--width", "16385"],
            error("outside 1..=16384"),
        ),
        with("--height 0", &["--height", "0"], error("outside 1..=16384")),
        with("--width -3", &["--width", "-3"], clap()),
        with("--iterations 0", &["--iterations", "0"], clap()),
        with(
            "--iterations with --time-budget",
            &["--time-budget", "1"],
            clap(),
        ),
        with("--photons -1", &["--photons", "-1"], clap()),
        with("--photons x", &["--photons", "x"], clap()),
        with("--radius nan", &["--radius", "nan"], clap()),
        with("--radius inf", &["--radius", "inf"], clap()),
        with("--radius -1", &["--radius", "-1"], clap()),
        with("--radius 0", &["--radius", "0"], clap()),
        with("--alpha nan", &["--alpha", "nan"], clap()),
        with("--iteration-ms inf", &["--iteration-ms", "inf"], clap()),
        with("--flattening inf", &["--flattening", "inf"], clap()),
        with("--preset bogus", &["--preset", "bogus"], clap()),
        with("--debug-view bogus", &["--debug-view", "bogus"], clap()),
        with("an unknown flag", &["--frobnicate"], clap()),
        with("--out x.jpg", &["--out", "{dir}/x.jpg"], clap()),
        with(
            "--out under a regular file",
            &["--out", "{dir}/scene.gltf/x.exr"],
            error("cannot"),
        ),
        with(
            "--stats under /proc",
            &["--stats", "/proc/x.json"],
            error("cannot write"),
        ),
        with(
            "--animation 5 of none",
            &["--animation", "5"],
            error("animation"),
        ),
        Case::new(
            "a scene that does not exist",
            g,
            vec![],
            render("nothing.gltf"),
            error("cannot read"),
        ),
        Case::new(
            "a folder as the scene",
            g,
            vec![("sub/x".into(), vec![])],
            render("sub"),
            error("not a file"),
        ),
    ];
    let renders: [(&str, &[&str]); 19] = [
        ("--photons 0", &["--photons", "0"]),
        ("--photons 1", &["--photons", "1"]),
        ("--photons 16777216", &["--photons", "16777216"]),
        ("--photons 4294967295", &["--photons", "4294967295"]),
        ("--iteration-ms 0.001", &["--iteration-ms", "0.001"]),
        ("--photon-depth 0", &["--photon-depth", "0"]),
        ("--photon-depth 1000", &["--photon-depth", "1000"]),
        ("--eye-depth 0", &["--eye-depth", "0"]),
        ("--eye-depth 1000", &["--eye-depth", "1000"]),
        ("--radius 256", &["--radius", "256"]),
        ("--alpha 0", &["--alpha", "0"]),
        ("--alpha 2", &["--alpha", "2"]),
        ("--cubemap 0", &["--cubemap", "0"]),
        ("--cubemap 100000", &["--cubemap", "100000"]),
        ("--bins 0", &["--bins", "0"]),
        ("--bins 1000", &["--bins", "1000"]),
        ("--tile 3", &["--tile", "3"]),
        ("--flattening 0", &["--flattening", "0"]),
        ("--subsampling 3", &["--subsampling", "3"]),
    ];
    cases.extend(
        renders
            .iter()
            .map(|(name, extra)| with(name, extra, Expect::Image).slow()),
    );
    cases.extend([
        with(
            "--width 1 --height 1",
            &["--width", "1", "--height", "1"],
            Expect::Image,
        )
        .slow(),
        with(
            "--width 4096 --height 1",
            &["--width", "4096", "--height", "1"],
            Expect::Image,
        )
        .slow(),
    ]);
    let command = |name: &str, files: Vec<(String, Vec<u8>)>, args: &[&str], expect| {
        Case::new(
            name,
            g,
            files,
            args.iter().map(|s| s.to_string()).collect(),
            expect,
        )
    };
    cases.extend([
        command(
            "compare of missing files",
            vec![],
            &["compare", "{dir}/a.exr", "{dir}/b.exr"],
            error("a.exr"),
        ),
        command(
            "compare of files that are not EXR",
            vec![
                ("a.exr".into(), b"nope".to_vec()),
                ("b.exr".into(), b"nope".to_vec()),
            ],
            &["compare", "{dir}/a.exr", "{dir}/b.exr"],
            error("a.exr"),
        ),
        command(
            "bench dirt on an empty file",
            vec![("empty.gltf".into(), vec![])],
            &["bench", "dirt", "{dir}/empty.gltf"],
            error("is not valid glTF"),
        ),
        command(
            "bench suite of a missing folder",
            vec![],
            &["bench", "suite", "{dir}/none", "--no-path-tracer"],
            error("none"),
        ),
        command(
            "bench suite of a folder without references",
            vec![("scene.gltf".into(), json_bytes(&base()))],
            &["bench", "suite", "{dir}", "--no-path-tracer"],
            error("no NAME.gltf"),
        ),
        command(
            "bench plot of a missing folder",
            vec![],
            &["bench", "plot", "{dir}/none"],
            error("none"),
        ),
        command(
            "bench trade of a missing scene",
            vec![],
            &[
                "bench",
                "trade",
                "{dir}/none.gltf",
                "--reference",
                "{dir}/none.exr",
            ],
            error("none.gltf"),
        ),
        command(
            "bench motion of a missing scene",
            vec![],
            &["bench", "motion", "{dir}/none.gltf"],
            error("none.gltf"),
        ),
    ]);
    cases
}
