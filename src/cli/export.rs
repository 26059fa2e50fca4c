//! `fmucal export`: the calibrated model, with the job's effects inside, as an FMI 2.0 FMU that
//! any FMI tool runs ([`fmucal_shared::export`] builds it). The runtime library inside is the
//! crate `fmucal-fmu`, built beside this binary; the export runs where the CLI runs.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use fmucal_shared::export::{Request, corrected_fmu, model_identifier};
use fmucal_shared::fmu::Fmu;
use fmucal_shared::job::{JobSpec, PreparedJob};
use fmucal_shared::quote::quote_user_text;

#[derive(clap::Args)]
pub struct Args {
    /// The job file (TOML): its model, its `[simulation] set` values and its effects.
    job: PathBuf,
    /// A folder written by `fmucal calibrate --out`: the calibrated values come from its
    /// result.json. Default: the job's start values (a job written by `fmucal diagnose` starts
    /// at its fit).
    #[arg(long)]
    result: Option<PathBuf>,
    /// The experiment whose settings become the defaults, for a job with [[experiments]].
    /// Default: the first.
    #[arg(long)]
    experiment: Option<String>,
    /// The FMU to write.
    #[arg(short, long)]
    output: PathBuf,
}

/// The runtime library's file name.
const RUNTIME: &str = "libfmucal_fmu.so";

/// The FMU runtime library: `$FMUCAL_FMU_RUNTIME`, else beside this executable (an install),
/// in cargo's `deps/` folder beside it (a cargo build), or in `../lib/fmucal/`.
pub(crate) fn runtime_library() -> Result<PathBuf> {
    if !(cfg!(target_os = "linux") && cfg!(target_arch = "x86_64")) {
        bail!("fmucal export writes x86_64 Linux FMUs and runs on x86_64 Linux only");
    }
    if let Some(p) = std::env::var_os("FMUCAL_FMU_RUNTIME") {
        let p = PathBuf::from(p);
        if !p.is_file() {
            bail!("FMUCAL_FMU_RUNTIME: {} is not a file", p.display());
        }
        return Ok(p);
    }
    let exe = std::env::current_exe().context("cannot find the fmucal executable")?;
    let dir = exe.parent().unwrap_or(Path::new("."));
    let candidates = [dir.join(RUNTIME), dir.join("deps").join(RUNTIME), dir.join("../lib/fmucal").join(RUNTIME)];
    candidates.iter().find(|p| p.is_file()).cloned().with_context(|| {
        format!(
            "the FMU runtime {RUNTIME} is not beside {} (build it with `cargo build --release`, or set FMUCAL_FMU_RUNTIME)",
            exe.display()
        )
    })
}

/// The calibrated values of `job` from `dir/result.json` (its `x_opt`), in the job's point
/// order, each within the job's bounds.
fn result_values(dir: &Path, job: &PreparedJob) -> Result<Vec<f64>> {
    let path = dir.join("result.json");
    fmucal_shared::job::limits::check_regular_file("--result", &path, fmucal_shared::job::limits::MAX_JOB_FILE_BYTES)?;
    let text = std::fs::read_to_string(&path).with_context(|| format!("--result: cannot read {}", path.display()))?;
    let value: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("--result: {} is not JSON", path.display()))?;
    let x_opt: std::collections::BTreeMap<String, f64> = value
        .get("x_opt")
        .and_then(|v| serde_json::from_value(v.clone()).ok())
        .with_context(|| format!("--result: {} has no x_opt of names and numbers", path.display()))?;
    let result = fmucal_shared::job::CalibrationResult { x_opt, ..Default::default() };
    let names = &job.parameter_names;
    if let Some(missing) = names.iter().find(|n| !result.x_opt.contains_key(*n)) {
        bail!(
            "--result: {} is from another job: it has no value for {} (its values: {})",
            dir.join("result.json").display(),
            quote_user_text(missing),
            quote_user_text(&result.x_opt.keys().cloned().collect::<Vec<_>>().join(", "))
        );
    }
    if let Some(extra) = result.x_opt.keys().find(|n| !names.contains(n)) {
        bail!(
            "--result: {} is from another job: the job calibrates no {}",
            dir.join("result.json").display(),
            quote_user_text(extra)
        );
    }
    let x = result.x_opt_in(names);
    let (_, _, lower, upper) = job.spec.parameter_vectors();
    for (((n, v), lo), hi) in names.iter().zip(&x).zip(&lower).zip(&upper) {
        if !v.is_finite() {
            bail!("--result: the value of {} is {v}, not a number", quote_user_text(n));
        }
        if v < lo || v > hi {
            bail!("--result: {} = {v} is outside the job's bounds [{lo}, {hi}]", quote_user_text(n));
        }
    }
    Ok(x)
}

/// Writes `bytes` to `path` through a temporary file beside it, so no half-made FMU is ever
/// left at `path`.
fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let tmp = tempfile::NamedTempFile::new_in(dir).with_context(|| format!("-o: cannot write in {}", dir.display()))?;
    std::fs::write(tmp.path(), bytes).with_context(|| format!("-o: cannot write {}", tmp.path().display()))?;
    tmp.persist(path).with_context(|| format!("-o: cannot write {}", path.display()))?;
    Ok(())
}

/// Where the exported values come from.
pub(crate) enum Values<'a> {
    /// The job's start values.
    Starts,
    /// A calibration's result folder.
    Result(&'a Path),
}

/// Exports `spec` at `values` into `output`; returns a one-line summary.
pub(crate) fn export(spec: &JobSpec, values: Values, experiment: Option<&str>, output: &Path) -> Result<String> {
    let model = super::calibrate::model_path(spec)?;
    if output.is_dir() {
        bail!("-o: {} is a folder; name the FMU file to write", output.display());
    }
    // Only a file named *.fmu is written, so a slip of the finger cannot replace the job or
    // its data.
    if !output.extension().is_some_and(|e| e.eq_ignore_ascii_case("fmu")) {
        bail!("-o: {} does not end in .fmu; name the FMU file to write", output.display());
    }
    if let (Ok(a), Ok(b)) = (std::fs::canonicalize(output), std::fs::canonicalize(&model))
        && a == b
    {
        bail!("-o: {} is the job's model itself; write the corrected FMU to another file", output.display());
    }
    let mut spec = spec.clone();
    spec.model.path = Some(model.clone());
    let data = fmucal_shared::job::data::read_all(&spec)?;
    let fmu = Fmu::load(&model).with_context(|| format!("cannot load {}", model.display()))?;
    let job = PreparedJob::new(&spec, &fmu.description, &fmu.interfaces(), &data)?;
    let x = match values {
        Values::Starts => job.spec.parameter_vectors().1,
        Values::Result(dir) => result_values(dir, &job)?,
    };
    let k = match experiment {
        None => 0,
        Some(name) => job.experiments.iter().position(|e| e.name == name).with_context(|| {
            let names: Vec<&str> = job.experiments.iter().map(|e| e.name.as_str()).filter(|n| !n.is_empty()).collect();
            format!(
                "--experiment: the job has no experiment {} ({})",
                quote_user_text(name),
                if names.is_empty() {
                    "it has no [[experiments]]".to_owned()
                } else {
                    format!("its experiments: {}", names.join(", "))
                }
            )
        })?,
    };
    let runtime_path = runtime_library()?;
    let runtime = std::fs::read(&runtime_path).with_context(|| format!("cannot read {}", runtime_path.display()))?;
    let bytes = corrected_fmu(&Request { fmu: &fmu, job: &job, experiment: k, x: &x, runtime: &runtime })?;
    write_atomically(output, &bytes)?;
    let interfaces =
        if fmu.description.model_exchange.is_some() { "Model Exchange and Co-Simulation" } else { "Co-Simulation" };
    let effects = job.spec.effects.len();
    Ok(format!(
        "wrote {} ({}, FMI 2.0, {interfaces}): {} calibrated value(s) as defaults, {effects} effect(s) inside",
        output.display(),
        model_identifier(&fmu.description),
        job.parameter_names.len()
    ))
}

pub fn run(args: Args) -> Result<()> {
    let spec = JobSpec::from_toml_file(&args.job)?;
    spec.validate()?;
    let values = args.result.as_deref().map_or(Values::Starts, Values::Result);
    println!("{}", export(&spec, values, args.experiment.as_deref(), &args.output)?);
    Ok(())
}
