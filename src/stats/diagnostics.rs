//! Bevy diagnostics under `rppm/`: iterations, GPU milliseconds per stage and memory held,
//! summed over every photon-mapping camera, for `DiagnosticsStore`, `LogDiagnosticsPlugin`
//! and on-screen overlays.

use bevy::diagnostic::{Diagnostic, DiagnosticPath, Diagnostics, RegisterDiagnostic};
use bevy::prelude::*;

use super::RppmStats;
use super::timing::Stage;

/// Iterations accumulated since the last reset (the largest over cameras).
pub const ITERATIONS: DiagnosticPath = DiagnosticPath::const_new("rppm/iterations");
/// Bytes held by the GPU resources of every camera and the scene, in MiB.
pub const MEMORY_MIB: DiagnosticPath = DiagnosticPath::const_new("rppm/memory_mib");

/// `rppm/gpu_ms/<stage>`: GPU milliseconds of the stage in the last timed frame.
pub fn stage_path(stage: Stage) -> DiagnosticPath {
    DiagnosticPath::new(format!("rppm/gpu_ms/{}", stage.name()))
}

pub(crate) fn register(app: &mut App) {
    app.register_diagnostic(Diagnostic::new(ITERATIONS))
        .register_diagnostic(Diagnostic::new(MEMORY_MIB).with_suffix(" MiB"));
    for stage in Stage::ALL {
        app.register_diagnostic(Diagnostic::new(stage_path(stage)).with_suffix(" ms"));
    }
    app.add_systems(PreUpdate, publish.after(super::receive_reports));
}

fn publish(stats: Res<RppmStats>, mut diagnostics: Diagnostics) {
    if stats.views.is_empty() {
        return;
    }
    let views = stats.views.values();
    diagnostics.add_measurement(&ITERATIONS, || {
        views.clone().map(|v| v.iteration).max().unwrap_or(0) as f64
    });
    diagnostics.add_measurement(&MEMORY_MIB, || {
        let bytes: u64 = views.clone().flat_map(|v| v.memory.values()).sum();
        bytes as f64 / (1u64 << 20) as f64
    });
    for stage in Stage::ALL {
        let ms: f64 = views
            .clone()
            .filter_map(|v| v.stage_ms.get(stage.name()))
            .sum();
        diagnostics.add_measurement(&stage_path(stage), || ms);
    }
}
