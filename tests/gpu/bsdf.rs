//! The BSDF keeps energy: the white furnace, on the GPU with the shaders' own functions
//! (`bsdf_eval` for splats and direct light, `scatter_photon` for photons).

use std::time::{Duration, Instant};

use bevy_rppm::debug::furnace::{FurnaceCase, FurnaceRequest, FurnaceResults, FurnaceRow};
use bevy_rppm::scene::GpuMaterial;

use crate::util::*;

fn material(base: f32, metallic: f32, roughness: f32) -> GpuMaterial {
    GpuMaterial {
        base_color: [base, base, base, 1.0],
        metallic,
        perceptual_roughness: roughness,
        reflectance: 0.5,
        ior: 1.5,
        ..Default::default()
    }
}

fn furnace(cases: Vec<FurnaceCase>) -> Vec<FurnaceRow> {
    let mut app = gpu_app();
    app.insert_resource(FurnaceRequest {
        cases,
        samples: 1 << 16,
    });
    let start = Instant::now();
    loop {
        app.update();
        if let Some(rows) = app.world_mut().resource_mut::<FurnaceResults>().0.take() {
            return rows;
        }
        assert!(
            start.elapsed() < Duration::from_secs(600),
            "the furnace did not finish in 10 minutes"
        );
    }
}

/// A surface of albedo 1 under uniform unit radiance reflects 1 ± 1 % toward any direction
/// (dielectric, metal and half of each, roughness 0.05…1), and photons keep 1 ± 2 % of their flux on
/// average. A rough dielectric (roughness ≥ 0.75) of albedo ½ reads within a few percent of
/// Lambert's ½ (the references' stand-in, CONVENTIONS.md) at every angle.
#[test]
fn white_furnace_reflects_all_light_at_every_roughness() {
    let roughness = [0.05, 0.1, 0.2, 0.3, 0.5, 0.75, 1.0];
    let cosines = [0.2, 0.5, 0.8, 1.0];
    let mut cases = Vec::new();
    for base in [1.0, 0.5] {
        for metallic in [0.0, 0.5, 1.0] {
            for &r in &roughness {
                for &cos_theta in &cosines {
                    cases.push((
                        base,
                        metallic,
                        r,
                        FurnaceCase {
                            material: material(base, metallic, r),
                            cos_theta,
                        },
                    ));
                }
            }
        }
    }
    let rows = furnace(cases.iter().map(|c| c.3).collect());
    assert_eq!(rows.len(), cases.len());
    let mut failures = Vec::new();
    println!("base metallic roughness cos  eval   photon");
    for ((base, metallic, r, case), row) in cases.iter().zip(&rows) {
        let (eval, photon) = (row.eval[1], row.photon[1]);
        println!(
            "{base:4} {metallic:8} {r:9} {:4} {eval:.4} {photon:.4}",
            case.cos_theta
        );
        if !(eval.is_finite() && photon.is_finite()) {
            failures.push(format!(
                "{base} {metallic} {r} {}: not finite",
                case.cos_theta
            ));
            continue;
        }
        if *base == 1.0 {
            if (eval - 1.0).abs() > 0.01 || (photon - 1.0).abs() > 0.02 {
                failures.push(format!(
                    "albedo 1, metallic {metallic}, roughness {r}, cos {}: eval {eval:.4}, photons {photon:.4}",
                    case.cos_theta
                ));
            }
        } else if *metallic == 0.0 && *r >= 0.75 {
            let ratio = eval / base;
            if !(0.97..=1.05).contains(&ratio) {
                failures.push(format!(
                    "albedo ½ dielectric, roughness {r}, cos {}: {ratio:.4} × Lambert",
                    case.cos_theta
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Rough glass (`scatter_photon`'s `ROUGH_REFRACTION` lobe) keeps what Mitsuba's
/// `roughdielectric` keeps (single scattering, ior 1.5, photons arriving from outside): its
/// mean sampled weight in importance mode, measured with Mitsuba 3.9 (50 000 samples each;
/// α = roughness²), within 0.03 (both estimates move by about 1 % between seeds at roughness
/// 1). At roughness 1 and a grazing 0.3 it keeps barely half.
#[test]
fn rough_glass_keeps_what_mitsubas_roughdielectric_keeps() {
    // (roughness, cos θ, Mitsuba's albedo)
    let expected = [
        (0.2, 0.3, 0.9950),
        (0.5, 0.3, 0.9386),
        (0.5, 1.0, 0.9921),
        (1.0, 0.3, 0.5653),
        (1.0, 1.0, 0.8946),
    ];
    let cases = expected.map(|(r, cos_theta, _)| FurnaceCase {
        material: GpuMaterial {
            specular_transmission: 1.0,
            ..material(1.0, 0.0, r)
        },
        cos_theta,
    });
    let rows = furnace(cases.to_vec());
    let mut failures = Vec::new();
    for ((r, cos_theta, mitsuba), row) in expected.iter().zip(&rows) {
        let kept = row.photon[1];
        println!(
            "rough glass, roughness {r}, cos {cos_theta}: photons keep {kept:.4}, Mitsuba {mitsuba}"
        );
        if !(kept.is_finite() && (kept - mitsuba).abs() <= 0.03) {
            failures.push(format!(
                "roughness {r}, cos {cos_theta}: {kept:.4} against {mitsuba}"
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
