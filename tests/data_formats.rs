//! The data files modellers have: MATLAB v4 result files as Dymola and
//! OpenModelica write them (checked against SciPy's reader), CSV separated by `;` or tab, a
//! `Time` column, column errors that name the job field and the closest columns, hostile v4
//! files refused in one line, and TOML errors in the parser's layout.

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

use fmucal_shared::job::MeasurementTable;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)
}

const V4: [&str; 3] = ["decay_dymola.mat", "decay_om.mat", "decay_normal.mat"];

/// Every variable of a v4 result file as SciPy's `loadmat` reads its matrices, resolved by
/// `dataInfo` (aliases, negated aliases, `data_1` constants) in Python: name → values.
fn scipy_variables(path: &Path) -> Vec<(String, Vec<f64>)> {
    let script = r#"
import json, sys
import numpy as np
import scipy.io
m = scipy.io.loadmat(sys.argv[1], chars_as_strings=False)
aclass = ["".join(r).strip() for r in m["Aclass"]]
trans = aclass[3] == "binTrans"
fix = (lambda a: a.T) if trans else (lambda a: a)
names = ["".join(r).rstrip(" \0") for r in fix(m["name"])]
info = fix(m["dataInfo"])
d1, d2 = fix(m["data_1"]).astype(float), fix(m["data_2"]).astype(float)
out = []
for name, row in zip(names, info):
    block, col = int(row[0]), int(row[1])
    sign = -1.0 if col < 0 else 1.0
    if block == 1:
        v = np.full(d2.shape[0], sign * d1[0, abs(col) - 1])
    else:
        v = sign * d2[:, abs(col) - 1]
    out.append([name, [float(x) for x in v]])
print(json.dumps(out))
"#;
    let out = std::process::Command::new(common::fmpy_python()).args(["-c", script]).arg(path).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn v4_result_files_read_as_scipy_reads_them_aliases_included() {
    for name in V4 {
        let path = fixture(name);
        let expected = scipy_variables(&path);
        let table = MeasurementTable::read(&path, "time").unwrap();
        // Time is Dymola's `Time` or OpenModelica's `time`, found either way.
        let (time_name, time) = &expected[0];
        assert!(time_name.eq_ignore_ascii_case("time"), "{name}: {time_name}");
        assert_eq!(&table.time, time, "{name}");
        let names: Vec<&str> = table.columns.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["k", "x", "der(x)", "xAlias", "minusX", "kAlias"], "{name}");
        for (variable, values) in &expected[1..] {
            assert_eq!(table.column(variable).unwrap(), values.as_slice(), "{name}: {variable}");
        }
        let x = table.column("x").unwrap();
        assert!(x[0] == 1.0 && x[20] < 0.04, "{name}: {x:?}");
        assert_eq!(table.column("minusX").unwrap(), x.iter().map(|v| -v).collect::<Vec<_>>(), "{name}");
        assert_eq!(table.column("xAlias").unwrap(), x, "{name}");
        let k = table.column("k").unwrap();
        assert!(k.iter().all(|&v| v == k[0] && (v - 1.7).abs() < 1e-6), "{name}: {k:?}");
        assert_eq!(table.column("kAlias").unwrap(), k.iter().map(|v| -v).collect::<Vec<_>>(), "{name}");
        // A selection keeps the variables asked for, and still names every one.
        let s = MeasurementTable::read_selected(&path, "time", Some(&["minusX"])).unwrap();
        assert_eq!(s.table.columns.len(), 1, "{name}");
        assert_eq!(s.names.len(), 6, "{name}");
    }
    // float32 trajectories are float32's numbers, float64 ones exact.
    let om = MeasurementTable::read(&fixture("decay_om.mat"), "time").unwrap();
    assert_eq!(om.column("x").unwrap()[1], (-1.7f64 * 0.1).exp());
    let dymola = MeasurementTable::read(&fixture("decay_dymola.mat"), "time").unwrap();
    assert_eq!(dymola.column("x").unwrap()[1], f64::from((-1.7f64 * 0.1).exp() as f32));
}

#[test]
fn csv_separators_and_a_time_column_in_another_case() {
    let comma = MeasurementTable::read(&fixture("decay_Time.csv"), "time").unwrap();
    assert_eq!(comma.columns.len(), 1);
    assert_eq!(comma.time.len(), 21);
    for name in ["decay_semicolon.csv", "decay_tab.csv"] {
        let t = MeasurementTable::read(&fixture(name), "time").unwrap();
        assert_eq!(t, comma, "{name}");
    }
    // Two columns that differ from `time` in case only: neither is taken, both are named.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("two.csv");
    std::fs::write(&p, "Time;TIME;x\n0;0;1\n").unwrap();
    let e = MeasurementTable::read(&p, "time").unwrap_err().to_string();
    assert!(e.ends_with("line 1: no column named \"time\"; did you mean \"Time\" or \"TIME\"?"), "{e}");
    std::fs::write(&p, "t_s;x\n0;1\n").unwrap();
    let e = MeasurementTable::read(&p, "time").unwrap_err().to_string();
    assert!(e.ends_with("line 1: no column named \"time\"; the closest: \"t_s\", \"x\""), "{e}");
}

/// Runs `fmucal ARGS` in `dir`.
fn fmucal(dir: &Path, args: &[&str]) -> Output {
    common::fmucal_in(dir).args(args).env_remove("FMUCAL_TOKEN").env_remove("FMUCAL_LOG").output().unwrap()
}

/// A decay job (`k` in 0.1..5, true 1.7) on `data`, its output `x` against `column`.
fn decay_job(dir: &Path, data: &Path, column: &str) -> PathBuf {
    let text = common::job_toml(
        Path::new("example:decay"),
        Some(data),
        &[("x", column)],
        &[],
        &[("k", 1.0, 0.1, 5.0)],
        "[optimizer]\nx_tol = 1e-6\nf_tol = 1e-12\n",
    );
    common::write_file(dir, "job.toml", text)
}

/// The one `error:` line of a failed run (exit code 1, no panic) and the lines after it.
fn refused(out: &Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!stderr.contains("panicked"), "panic: {stderr}");
    assert_eq!(out.status.code(), Some(1), "exit code; stderr: {stderr}");
    assert_eq!(stderr.lines().filter(|l| l.starts_with("error: ")).count(), 1, "{stderr}");
    stderr[stderr.find("error: ").unwrap()..].trim_end().to_owned()
}

#[test]
fn calibrate_fits_a_v4_result_file_and_each_csv_layout() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The negated alias of the Dymola file (float32, `Time`), the alias of OpenModelica's, and
    // the CSV layouts: each gives k = 1.7.
    let cases = [
        ("decay_dymola.mat", "x", 1e-4),
        ("decay_om.mat", "xAlias", 1e-5),
        ("decay_semicolon.csv", "x", 1e-5),
        ("decay_tab.csv", "x", 1e-5),
        ("decay_Time.csv", "x", 1e-5),
    ];
    for (file, column, tol) in cases {
        let job = decay_job(d, &fixture(file), column);
        let out_dir = d.join(format!("out-{file}"));
        let out = fmucal(d, &["calibrate", job.to_str().unwrap(), "--out", out_dir.to_str().unwrap()]);
        assert!(out.status.success(), "{file}: {}", String::from_utf8_lossy(&out.stderr));
        let result: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out_dir.join("result.json")).unwrap()).unwrap();
        let k = result["x_opt"]["k"].as_f64().unwrap();
        assert!((k - 1.7).abs() < tol, "{file}: k = {k}");
    }
}

#[test]
fn a_missing_column_names_the_field_and_the_closest_columns() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let job = decay_job(d, &fixture("decay_om.mat"), "minusx");
    let line = refused(&fmucal(d, &["calibrate", job.to_str().unwrap(), "--out", "out"]));
    assert_eq!(
        line,
        "error: outputs[0].column: no column \"minusx\" in the data; the closest: \"minusX\", \"x\", \"k\", \"der(x)\", \"xAlias\""
    );
    let job = decay_job(d, &fixture("decay_tab.csv"), "y");
    let line = refused(&fmucal(d, &["calibrate", job.to_str().unwrap(), "--out", "out"]));
    assert_eq!(line, "error: outputs[0].column: no column \"y\" in the data; the closest: \"x\"");
}

#[test]
fn hostile_v4_files_are_refused_in_one_line_without_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let whole = std::fs::read(fixture("decay_om.mat")).unwrap();
    let p = dir.path().join("cut.mat");
    // Every truncation: an error (never a panic), or, cut between matrices, a file that lacks
    // one and says so.
    for n in 0..whole.len() {
        std::fs::write(&p, &whole[..n]).unwrap();
        let e = MeasurementTable::read(&p, "time").unwrap_err().to_string();
        assert!(!e.contains('\n') && e.starts_with(&format!("cannot read {}: ", p.display())), "{n}: {e}");
        assert!(["truncated", "no ", "neither a MATLAB", "invalid"].iter().any(|w| e.contains(w)), "{n} bytes: {e}");
    }
    // Headers that claim more than the file holds, negative sizes, unknown formats, and
    // dataInfo pointing outside the data.
    let header = |mopt: i32, rows: i32, cols: i32, imagf: i32, namlen: i32| {
        [mopt, rows, cols, imagf, namlen].iter().flat_map(|v| v.to_le_bytes()).chain(*b"x\0").collect::<Vec<u8>>()
    };
    let mut bad_info = whole.clone();
    // The OpenModelica file's dataInfo: x's column (the third variable, binTrans: 4 ints a
    // variable) set past data_2's 3.
    let info_at = find(&whole, b"dataInfo\0") + 9;
    bad_info[info_at + 2 * 16 + 4..info_at + 2 * 16 + 8].copy_from_slice(&7i32.to_le_bytes());
    let cases: Vec<(Vec<u8>, &str)> = vec![
        (header(0, i32::MAX, i32::MAX, 0, 2), "more than the file holds"),
        (header(0, -1, 1, 0, 2), "-1 rows"),
        (header(0, 1, 1, 0, i32::MAX), "runs past the end"),
        (header(2000, 1, 1, 0, 2), "VAX or Cray"),
        (header(0, 0, i32::MAX, 0, 2), "more than the file holds"),
        (header(0, 1, 1, 3, 2), "imaginary flag 3"),
        (bad_info, "dataInfo of \"x\" points to column 7 of a matrix of 3"),
    ];
    for (bytes, says) in cases {
        std::fs::write(&p, &bytes).unwrap();
        let e = MeasurementTable::read(&p, "time").unwrap_err().to_string();
        assert!(!e.contains('\n') && e.contains(says), "{says}: {e}");
    }
    // Through the CLI: one line, exit code 1.
    std::fs::write(&p, &whole[..whole.len() - 3]).unwrap();
    let job = decay_job(dir.path(), &p, "x");
    let line = refused(&fmucal(dir.path(), &["calibrate", job.to_str().unwrap(), "--out", "out"]));
    assert!(!line.contains('\n') && line.contains("cut.mat: truncated MATLAB v4 file"), "{line}");
}

fn find(haystack: &[u8], needle: &[u8]) -> usize {
    haystack.windows(needle.len()).position(|w| w == needle).unwrap()
}

#[test]
fn toml_errors_keep_the_caret_layout_and_quote_one_bounded_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let job = decay_job(d, &fixture("decay_tab.csv"), "x");
    common::edit_file(&job, |text| text.replace("lower = 0.1", "lower = 0.1.2"));
    let out = refused(&fmucal(d, &["calibrate", job.to_str().unwrap(), "--out", "out"]));
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 5, "{out}");
    assert_eq!(lines[0], "error: toml: TOML parse error at line 11, column 12", "{out}");
    assert_eq!(lines[1], "   |");
    assert_eq!(lines[2], "11 | lower = 0.1.2");
    assert_eq!(lines[3], "   |            ^");
    // A long line is quoted around the column, escaped.
    let long = format!("[model]\npath = \"{}\u{202e}\" = 1\n", "y".repeat(100_000));
    std::fs::write(&job, long).unwrap();
    let out = refused(&fmucal(d, &["calibrate", job.to_str().unwrap(), "--out", "out"]));
    let lines: Vec<&str> = out.lines().collect();
    assert!(lines.len() == 5 && out.len() < 600 && !out.contains('\u{202e}'), "{out}");
    let caret = lines[3].chars().position(|c| c == '^').unwrap();
    assert_eq!(lines[2].chars().nth(caret), Some('='), "{out}");
}
