//! The paper's first example end to end (section 6.1): `fmucal calibrate
//! examples/furuta/job.toml` recovers the friction coefficients that generated the committed
//! measurements (`examples/furuta/generate.sh`, fixed seed) within 5 %.

use std::process::Command;

#[test]
fn furuta_frictions_are_recovered_within_5_percent() {
    let dir = tempfile::tempdir().unwrap();
    let job = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/furuta/job.toml");
    let out = Command::new(env!("CARGO_BIN_EXE_fmucal"))
        .args(["calibrate", job.to_str().unwrap(), "--out"])
        .arg(dir.path())
        .env("FMUCAL_CACHE_DIR", dir.path().join("cache"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("result.json")).unwrap()).unwrap();
    for (name, truth) in [("armFriction", 0.010), ("pendulumFriction", 0.0010)] {
        let got = r["x_opt"][name].as_f64().unwrap();
        let err = (got - truth).abs() / truth;
        assert!(err < 0.05, "{name}: recovered {got}, generated with {truth} ({:.1} % off)", 100.0 * err);
    }
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("armFriction = ") && stdout.contains("pendulumFriction = "), "{stdout}");
}
