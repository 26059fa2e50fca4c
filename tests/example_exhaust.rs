//! The paper's second example end to end (section 6.2), on the committed data
//! (`examples/exhaust/generate.sh`, fixed seed): the two-stage calibration (right volume, then
//! left volume with the right one fixed) on the first third of the data reaches a scaled RMS
//! error ≤ 0.3 and validates below 1 on the rest; fitting all four parameters at once shows
//! correlations near ±1 (over-parameterization) where the two-stage fits do not.

use std::path::Path;
use std::process::Command;

use fmucal_shared::job::CalibrationResult;
use fmucal_shared::job::identifiability::Identifiability;

fn calibrate(dir: &Path, job: &str, out: &str) -> CalibrationResult {
    let run = Command::new(env!("CARGO_BIN_EXE_fmucal"))
        .args(["calibrate", job, "--out", out])
        .current_dir(dir)
        .env("FMUCAL_CACHE_DIR", dir.join("cache"))
        .output()
        .unwrap();
    assert!(run.status.success(), "{job}: {}", String::from_utf8_lossy(&run.stderr));
    serde_json::from_str(&std::fs::read_to_string(dir.join(out).join("result.json")).unwrap()).unwrap()
}

fn identifiability(r: &CalibrationResult) -> &Identifiability {
    r.identifiability.as_ref().unwrap_or_else(|| panic!("no identifiability analysis: {r:?}"))
}

fn max_abs_correlation(r: &CalibrationResult) -> f64 {
    let c = &identifiability(r).correlation;
    let mut m = 0.0f64;
    for (i, row) in c.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            if i != j {
                assert!(v.is_finite(), "correlation [{i}][{j}] is {v}");
                m = m.max(v.abs());
            }
        }
    }
    m
}

#[test]
fn two_stage_fit_calibrates_and_validates_and_all_four_is_over_parameterized() {
    let dir = tempfile::tempdir().unwrap();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/exhaust");
    for f in ["exhaust_data.csv", "stage1_right.toml", "stage2_left.toml", "all_four.toml"] {
        std::fs::copy(src.join(f), dir.path().join(f)).unwrap();
    }
    let stage1 = calibrate(dir.path(), "stage1_right.toml", "stage1");
    let stage2 = calibrate(dir.path(), "stage2_left.toml", "stage2");
    let all4 = calibrate(dir.path(), "all_four.toml", "all4");

    let errors = stage2.errors.as_ref().unwrap();
    let cal = errors.calibration.scaled_rms;
    let val = errors.validation.as_ref().unwrap().scaled_rms;
    println!("two-stage scaled RMS: calibration {cal:.3}, validation {val:.3}");
    assert!(cal <= 0.3, "calibration scaled RMS {cal}");
    assert!(val < 1.0, "validation scaled RMS {val}");
    assert!(stage1.errors.as_ref().unwrap().calibration.scaled_rms < 1.0);

    let (c1, c2, c4) = (max_abs_correlation(&stage1), max_abs_correlation(&stage2), max_abs_correlation(&all4));
    println!("largest |correlation|: stage 1 {c1:.3}, stage 2 {c2:.3}, all four {c4:.3}");
    assert!(c4 >= 0.9, "fitting all four should show near-±1 correlations, got {c4}");
    assert!(c1 < 0.5 && c2 < 0.5, "the two-stage fits should not: {c1}, {c2}");
    for r in [&stage1, &stage2, &all4] {
        let se = &identifiability(r).standard_errors;
        assert!(se.iter().all(|v| *v > 0.0), "{r:?}");
    }
}
