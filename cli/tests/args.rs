//! The command line's shape, without a GPU: help on every command, one error line and exit
//! code 2 for bad flags.

use std::process::{Command, Output};

fn rppm(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rppm"))
        .args(args)
        .output()
        .expect("run rppm")
}

#[test]
fn every_command_has_help() {
    for args in [
        &["--help"][..],
        &["render", "--help"],
        &["compare", "--help"],
        &["bench", "--help"],
        &["bench", "dirt", "--help"],
        &["bench", "trade", "--help"],
    ] {
        let out = rppm(args);
        assert!(out.status.success(), "{args:?}: {out:?}");
        let help = String::from_utf8_lossy(&out.stdout);
        assert!(help.contains("Usage: rppm"), "{args:?}: {help}");
    }
    let render = String::from_utf8_lossy(&rppm(&["render", "--help"]).stdout).to_string();
    for flag in [
        "--time-budget",
        "--photons",
        "--preset",
        "--debug-view",
        "--stats",
    ] {
        assert!(render.contains(flag), "{flag} missing from: {render}");
    }
}

#[test]
fn bad_flags_give_one_error_line_and_exit_code_2() {
    for args in [
        &["render", "x.gltf", "--frobnicate"][..],
        &["render"],
        &["render", "x.gltf", "--iterations", "0"],
        &[
            "render",
            "x.gltf",
            "--iterations",
            "2",
            "--time-budget",
            "3",
        ],
        &["render", "x.gltf", "--time-budget", "-1"],
        &["render", "x.gltf", "--out", "x.jpg"],
        &["render", "x.gltf", "--preset", "fastest"],
        &["bench", "dirt", "x.gltf", "--tile", "3"],
        &["bench", "trade", "x.gltf"],
        &["frobnicate"],
    ] {
        let out = rppm(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {out:?}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(stderr.lines().count(), 1, "{args:?}: {stderr}");
        assert!(stderr.starts_with("rppm: error:"), "{args:?}: {stderr}");
    }
}
