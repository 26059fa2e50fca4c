//! Bad input through the real `fmucal` binary: every case must print exactly one `error:` line
//! naming the problem, exit with code 1, and never panic.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

struct Run {
    code: Option<i32>,
    stderr: String,
}

fn fmucal(args: &[&str], cache: &Path, env: &[(&str, &str)]) -> Run {
    let out = Command::new(env!("CARGO_BIN_EXE_fmucal"))
        .args(args)
        .env("FMUCAL_CACHE_DIR", cache)
        .envs(env.iter().copied())
        .output()
        .expect("run fmucal");
    Run { code: out.status.code(), stderr: String::from_utf8_lossy(&out.stderr).into_owned() }
}

/// Asserts a clean one-line failure whose message contains every `needle`.
fn assert_fails(run: &Run, needles: &[&str]) {
    assert!(!run.stderr.contains("panicked"), "panic: {}", run.stderr);
    assert_eq!(run.code, Some(1), "exit code, stderr: {}", run.stderr);
    let lines: Vec<&str> = run.stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "expected one line, got: {}", run.stderr);
    assert!(lines[0].starts_with("error: "), "{}", lines[0]);
    for n in needles {
        assert!(lines[0].contains(n), "{:?} not in {:?}", n, lines[0]);
    }
}

fn simulate(model: &Path, extra: &[&str], cache: &Path) -> Run {
    let mut args = vec!["simulate", model.to_str().unwrap(), "-o", "/dev/null"];
    args.extend_from_slice(extra);
    fmucal(&args, cache, &[])
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    common::write_file(dir, name, text)
}

#[test]
fn corrupt_zip() {
    let tmp = tempfile::tempdir().unwrap();
    let bad = write(tmp.path(), "bad.fmu", "this is not a zip archive");
    assert_fails(&simulate(&bad, &[], tmp.path()), &["not a valid zip archive"]);
    // A real archive cut in half.
    let bytes = std::fs::read(common::example("furuta")).unwrap();
    let cut = tmp.path().join("cut.fmu");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    assert_fails(&simulate(&cut, &[], tmp.path()), &["not a valid zip archive"]);
}

#[test]
fn entries_that_escape_the_archive() {
    let tmp = tempfile::tempdir().unwrap();
    for (entry, reason) in [("../evil.txt", "'..'"), ("/tmp/evil.txt", "absolute path")] {
        let mut entries = common::entries(&common::example("decay"));
        entries.push((entry.to_owned(), b"x".to_vec()));
        let fmu = tmp.path().join("escape.fmu");
        common::write_zip(&fmu, &entries);
        assert_fails(&simulate(&fmu, &[], tmp.path()), &["unsafe entry", entry, reason]);
    }
    assert!(!tmp.path().join("evil.txt").exists() && !Path::new("/tmp/evil.txt").exists());
}

#[test]
fn symlink_entry() {
    let tmp = tempfile::tempdir().unwrap();
    let fmu = tmp.path().join("link.fmu");
    let mut zip = zip::ZipWriter::new(std::fs::File::create(&fmu).unwrap());
    let opts = zip::write::SimpleFileOptions::default();
    zip.add_symlink("resources/passwd", "/etc/passwd", opts).unwrap();
    zip.finish().unwrap();
    assert_fails(&simulate(&fmu, &[], tmp.path()), &["unsafe entry", "symbolic link"]);
}

#[test]
fn archive_over_the_size_cap() {
    let tmp = tempfile::tempdir().unwrap();
    let model = common::example("furuta");
    let run = fmucal(
        &["simulate", model.to_str().unwrap(), "-o", "/dev/null"],
        tmp.path(),
        &[("FMUCAL_MAX_UNPACK_BYTES", "10000")],
    );
    assert_fails(&run, &["exceeds the unpacking limit", "declared uncompressed size over 10000 bytes"]);
    let run = fmucal(&["inspect", model.to_str().unwrap()], tmp.path(), &[("FMUCAL_MAX_UNPACK_ENTRIES", "2")]);
    assert_fails(&run, &["exceeds the unpacking limit", "limit 2"]);
}

#[test]
fn no_binary_for_this_platform_lists_those_present() {
    let tmp = tempfile::tempdir().unwrap();
    let fmu =
        common::repack("decay", tmp.path(), "nolinux.fmu", |n, b| (!n.starts_with("binaries/linux64")).then_some(b));
    assert_fails(
        &simulate(&fmu, &[], tmp.path()),
        &["no linux64 binary", "binaries/linux64/Decay.so", "platforms present: darwin64, win32, win64"],
    );
}

#[test]
fn binary_missing_an_fmi2_symbol() {
    let tmp = tempfile::tempdir().unwrap();
    let fmu = fmucal_models::Fixture::MissingSymbol.path();
    assert_fails(&simulate(&fmu, &[], tmp.path()), &["does not export fmi2GetReal"]);
}

#[test]
fn malformed_truncated_and_unsupported_descriptions() {
    let tmp = tempfile::tempdir().unwrap();
    let cases: [(&str, fn(String) -> String, &[&str]); 5] = [
        ("truncated.fmu", |x| x[..x.len() / 2].to_owned(), &["malformed modelDescription.xml"]),
        (
            "garbage.fmu",
            |x| x.replacen("<ModelVariables>", "<ModelVariables><<<", 1),
            &["malformed modelDescription.xml"],
        ),
        // A 2.0 description that claims another version is read as that version's.
        (
            "fmi1.fmu",
            |x| x.replace("fmiVersion=\"2.0\"", "fmiVersion=\"1.0\""),
            &["<fmiModelDescription> has no modelIdentifier attribute"],
        ),
        (
            "fmi3.fmu",
            |x| x.replace("fmiVersion=\"2.0\"", "fmiVersion=\"3.0\""),
            &["<fmiModelDescription> has no instantiationToken attribute"],
        ),
        (
            "fmi4.fmu",
            |x| x.replace("fmiVersion=\"2.0\"", "fmiVersion=\"4.0\""),
            &["FMI 4.0 FMUs are not supported (fmucal reads FMI 1.0, 2.0 and 3.0)"],
        ),
    ];
    for (file, edit, needles) in cases {
        let fmu = common::with_xml("furuta", tmp.path(), file, edit);
        assert_fails(&simulate(&fmu, &[], tmp.path()), needles);
    }
}

#[test]
fn bad_set_values() {
    let tmp = tempfile::tempdir().unwrap();
    let furuta = common::example("furuta");
    let cases: [(&str, &[&str]); 6] = [
        ("armFrction=0.1", &["unknown variable \"armFrction\""]),
        ("armFriction=fast", &["armFriction", "is not a number"]),
        ("armFriction=-1", &["armFriction = -1 is below its minimum 0"]),
        ("der(armJoint.phi)=1", &["\"der(armJoint.phi)\" may not be set"]),
        ("armFriction", &["is not of the form NAME=VALUE"]),
        ("armFriction=nan", &["not a finite number"]),
    ];
    for (set, needles) in cases {
        assert_fails(&simulate(&furuta, &["--set", set], tmp.path()), needles);
    }
    let decay = common::example("decay");
    assert_fails(&simulate(&decay, &["--set", "resourceFactor=3"], tmp.path()), &["may not be set"]);
    assert_fails(&simulate(&decay, &["--set", "power=2.5"], tmp.path()), &["is not an integer"]);
    assert_fails(&simulate(&decay, &["--set", "enabled=maybe"], tmp.path()), &["is not a boolean"]);
}

#[test]
fn bad_input_csv() {
    let tmp = tempfile::tempdir().unwrap();
    let furuta = common::example("furuta");
    let cases: [(&str, &[&str]); 6] = [
        ("time,u\n0,0\n2,1\n1,0\n", &["not monotonic", "row 3"]),
        ("time,u\n0,0\n1,nan\n", &["column \"u\"", "row 2", "not a finite number"]),
        ("time,u,armJoint.tauExt\n0,0,0\n1,1\n", &["line 3", "column \"armJoint.tauExt\" is missing"]),
        ("time,u\n0,0\n1,x\n", &["line 3", "\"x\" is not a number"]),
        ("t,u\n0,0\n", &["first column must be named \"time\""]),
        ("time,armFriction\n0,0\n", &["\"armFriction\" is not an input"]),
    ];
    for (i, (csv, needles)) in cases.iter().enumerate() {
        let input = write(tmp.path(), &format!("in{i}.csv"), csv);
        assert_fails(&simulate(&furuta, &["--input", input.to_str().unwrap()], tmp.path()), needles);
    }
}

#[test]
fn fmu_error_during_a_step() {
    let tmp = tempfile::tempdir().unwrap();
    let decay = common::example("decay");
    for (interface, function) in [("me", "fmi2GetDerivatives returned Error"), ("cs", "fmi2DoStep returned Error")] {
        let run = simulate(
            &decay,
            &["--interface", interface, "--set", "crashMode=error", "--set", "crashTime=0.5"],
            tmp.path(),
        );
        assert_fails(&run, &[function, "at t=0.", "crashMode=error reached"]);
    }
}

#[test]
fn bad_simulation_settings() {
    let tmp = tempfile::tempdir().unwrap();
    let furuta = common::example("furuta");
    let times = write(tmp.path(), "times.csv", "time\n0\n2\n1\n");
    let cases: [(Vec<&str>, &[&str]); 5] = [
        (vec!["--output", "nope"], &["unknown output variable \"nope\""]),
        (vec!["--stop-time", "-1"], &["stop time -1 must be a finite number after start time 0"]),
        (vec!["--tolerance", "2"], &["tolerance 2 must be in (0, 1)"]),
        (vec!["--output-times", times.to_str().unwrap()], &["output times must increase"]),
        (vec!["--output-interval", "0"], &["output interval 0 must be a positive number"]),
    ];
    for (args, needles) in cases {
        assert_fails(&simulate(&furuta, &args, tmp.path()), needles);
    }
    assert_fails(&fmucal(&["simulate", "no-such-model"], tmp.path(), &[]), &["no such file \"no-such-model\""]);
}

#[test]
fn built_in_examples_come_from_the_binary_itself() {
    // A copy of the binary far from its build tree, as after `cargo install` or in an image.
    let tmp = tempfile::tempdir().unwrap();
    let bin = tmp.path().join("fmucal");
    std::fs::copy(env!("CARGO_BIN_EXE_fmucal"), &bin).unwrap();
    let cache = tmp.path().join("cache");
    let run = |args: &[&str]| Command::new(&bin).args(args).env("FMUCAL_CACHE_DIR", &cache).output().unwrap();
    let out = run(&["examples"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let listing = String::from_utf8_lossy(&out.stdout);
    for (name, built) in fmucal_models::examples() {
        let line =
            listing.lines().find(|l| l.split_whitespace().next() == Some(name)).unwrap_or_else(|| panic!("{listing}"));
        let path = PathBuf::from(line.split_whitespace().nth(1).unwrap());
        assert!(path.starts_with(cache.join("examples")), "{name} at {}", path.display());
        assert_eq!(std::fs::read(&path).unwrap(), std::fs::read(&built).unwrap(), "{name}");
    }
    let out = run(&["inspect", "example:decay"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("kickTime"));
    let out = run(&["simulate", "example:nonesuch", "-o", "/dev/null"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("examples: furuta, bouncing-ball, decay"));
}

/// Mistakes in a multi-experiment job fail before any process starts, in one line naming the
/// experiment's field.
#[test]
fn bad_experiments_name_their_field() {
    let tmp = tempfile::tempdir().unwrap();
    let job = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/furuta_experiments/job.toml");
    let text = std::fs::read_to_string(&job).unwrap();
    let dir = job.parent().unwrap();
    let cases: [(&str, &str, &[&str]); 5] = [
        ("data = { path = \"steps.csv\" }", "data = { path = \"nope.csv\" }", &["nope.csv"]),
        (
            "data = { path = \"steps.csv\" }",
            "data = { path = \"steps.csv\" }\noutputs = [{ variable = \"armJoint.phi\", column = \"arm\" }]",
            &["experiments[1].outputs[0].column: no column \"arm\" in the data; the closest: "],
        ),
        ("name = \"steps\"", "name = \"sine\"", &["experiments[1].name", "appears twice"]),
        ("lower = -1.5", "lower = -1.5\nscale = \"log\"", &["parameters[2].lower", "positive lower bound"]),
        (
            "starts = { \"pendulumJoint.phi\" = 0.6 }",
            "starts = { armFriction = 0.6 }",
            &["experiments[1].starts.armFriction", "per_experiment"],
        ),
    ];
    for (from, to, needles) in cases {
        assert!(text.contains(from), "{from}");
        let path = tmp.path().join("job.toml");
        // Relative data paths resolve against the job file's folder: keep it beside the data.
        let text = text.replace(from, to).replace("path = \"", &format!("path = \"{}/", dir.display()));
        let text = text.replace(&format!("path = \"{}/example:", dir.display()), "path = \"example:");
        std::fs::write(&path, text).unwrap();
        let run = fmucal(
            &["calibrate", path.to_str().unwrap(), "--out", tmp.path().join("out").to_str().unwrap()],
            tmp.path(),
            &[],
        );
        assert_fails(&run, needles);
    }
}
