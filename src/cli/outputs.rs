//! The files of a calibration folder (`fmucal calibrate --out`): `result.json` (the
//! [`CalibrationResult`]), `convergence.csv` (its history) and `fit.csv` (the [`FitTable`]:
//! time, then `NAME:measured`, `NAME:start`, `NAME:optimized` per output, empty where a
//! value is missing; `start` is the model at the job's start values, and files written before
//! that name, which say `NAME:nominal`, are still read). Written from the typed data, and
//! read back for `fmucal plot`.

use std::path::Path;

use anyhow::{Context, Result, bail};
use fmucal_shared::job::report::FitColumns;
use fmucal_shared::job::{CalibrationResult, FitTable};

const KINDS: [&str; 3] = ["measured", "start", "optimized"];

/// The old name of the `start` column, read for one release.
const OLD_START: &str = "nominal";

/// An output folder (`--out`) made for a run: if the run ends without writing anything into
/// it, the folders it made are removed again, so a failed job leaves no empty folder behind
/// (a folder that existed before is left as it was, and so is one with anything in it).
pub struct OutDir {
    /// The folders this run made, the deepest first.
    made: Vec<std::path::PathBuf>,
}

impl OutDir {
    /// Makes `path` and any missing parents.
    ///
    /// # Errors
    /// If the folder cannot be made; the error names it.
    pub fn create(path: &Path) -> Result<OutDir> {
        let made: Vec<std::path::PathBuf> =
            path.ancestors().take_while(|a| !a.as_os_str().is_empty() && !a.exists()).map(Path::to_owned).collect();
        let dir = OutDir { made };
        std::fs::create_dir_all(path).with_context(|| format!("--out: cannot create {}", path.display()))?;
        Ok(dir)
    }
}

impl Drop for OutDir {
    fn drop(&mut self) {
        // `remove_dir` removes only empty folders: whatever the run wrote stays.
        for dir in &self.made {
            if std::fs::remove_dir(dir).is_err() {
                break;
            }
        }
    }
}

/// Writes `fit.csv`, `result.json` and `convergence.csv` into `dir`.
pub fn write(dir: &Path, result: &CalibrationResult, fit: &FitTable) -> Result<()> {
    write_fit(dir, fit)?;
    write_result(dir, result)
}

/// Writes `fit.csv` into `dir` (an experiment's folder, for a job with several).
pub fn write_fit(dir: &Path, fit: &FitTable) -> Result<()> {
    std::fs::write(dir.join("fit.csv"), fit_csv(fit))?;
    Ok(())
}

/// Writes `result.json` and `convergence.csv` into `dir`.
pub fn write_result(dir: &Path, result: &CalibrationResult) -> Result<()> {
    std::fs::write(dir.join("result.json"), serde_json::to_string_pretty(result)?)?;
    let mut conv = String::from("round,evaluations,best_f,batch_wall_s\n");
    for h in &result.history {
        conv.push_str(&format!("{},{},{},{}\n", h.round, h.evaluations, h.best_f, h.batch_wall_s));
    }
    std::fs::write(dir.join("convergence.csv"), conv)?;
    Ok(())
}

/// Reads `result.json` and the `fit.csv` files from a folder [`write`] wrote: its own, or one
/// per experiment (in `DIR/NAME`) for a job with several. The outputs' units come from
/// `result.json` (`fit.csv` keeps plain variable names in its header).
pub fn read(dir: &Path) -> Result<(CalibrationResult, Vec<(std::path::PathBuf, FitTable)>)> {
    let path = dir.join("result.json");
    let text = std::fs::read_to_string(&path).with_context(|| format!("cannot read {}", path.display()))?;
    let result: CalibrationResult =
        serde_json::from_str(&text).with_context(|| format!("cannot read {}", path.display()))?;
    let dirs: Vec<std::path::PathBuf> = if result.experiments.is_empty() {
        vec![dir.to_owned()]
    } else {
        result.experiments.iter().map(|e| dir.join(&e.name)).collect()
    };
    let mut fits: Vec<(std::path::PathBuf, FitTable)> =
        dirs.into_iter().map(|d| Ok((d.clone(), read_fit(&d.join("fit.csv"))?))).collect::<Result<_>>()?;
    for o in fits.iter_mut().flat_map(|(_, fit)| &mut fit.outputs) {
        o.unit = result.units.get(&o.variable).cloned();
    }
    Ok((result, fits))
}

fn fit_csv(fit: &FitTable) -> String {
    let mut header = vec!["time".to_owned()];
    for o in &fit.outputs {
        header.extend(KINDS.map(|kind| format!("{}:{kind}", o.variable)));
    }
    let mut text = header.join(",") + "\n";
    let cell = |v: Option<f64>| v.map(|v| format!("{v}")).unwrap_or_default();
    for (i, t) in fit.time.iter().enumerate() {
        let mut row = vec![format!("{t}")];
        for o in &fit.outputs {
            let measured = o.measured.get(i).copied().filter(|m| !m.is_nan());
            let at = |c: &[Option<f64>]| c.get(i).copied().flatten();
            row.extend([cell(measured), cell(at(&o.nominal)), cell(at(&o.optimized))]);
        }
        text.push_str(&(row.join(",") + "\n"));
    }
    text
}

fn read_fit(path: &Path) -> Result<FitTable> {
    let context = || format!("cannot read {}", path.display());
    let mut reader = csv::Reader::from_path(path).with_context(context)?;
    let header = reader.headers().with_context(context)?.clone();
    if header.get(0) != Some("time") {
        bail!("{}: the first column is not time", path.display());
    }
    let columns: Vec<&str> = header.iter().skip(1).collect();
    let mut outputs = vec![];
    for group in columns.chunks(3) {
        let variable = group[0].strip_suffix(":measured").unwrap_or_default();
        let expected = KINDS.map(|kind| format!("{variable}:{kind}"));
        let old = [&expected[0], &format!("{variable}:{OLD_START}"), &expected[2]];
        if variable.is_empty() || (group != expected && group != old) {
            bail!("{}: expected time, then NAME:measured,NAME:start,NAME:optimized per output", path.display());
        }
        outputs.push(FitColumns {
            variable: variable.to_owned(),
            unit: None,
            measured: vec![],
            nominal: vec![],
            optimized: vec![],
        });
    }
    let mut time = vec![];
    for (row, record) in reader.records().enumerate() {
        let record = record.with_context(context)?;
        let cell = |k: usize| -> Result<Option<f64>> {
            match record.get(k).unwrap_or_default() {
                "" => Ok(None),
                c => c
                    .parse()
                    .map(Some)
                    .with_context(|| format!("{}: row {}: {c:?} is not a number", path.display(), row + 1)),
            }
        };
        time.push(cell(0)?.with_context(|| format!("{}: row {} has no time", path.display(), row + 1))?);
        for (j, o) in outputs.iter_mut().enumerate() {
            o.measured.push(cell(1 + 3 * j)?.unwrap_or(f64::NAN));
            o.nominal.push(cell(2 + 3 * j)?);
            o.optimized.push(cell(3 + 3 * j)?);
        }
    }
    Ok(FitTable { time, outputs })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fit_csv_round_trips_with_gaps() {
        let fit = FitTable {
            time: vec![0.0, 0.5, 1.0 / 3.0],
            outputs: vec![
                FitColumns {
                    variable: "x".into(),
                    unit: None,
                    measured: vec![1.0, f64::NAN, 0.1 + 0.2],
                    nominal: vec![Some(2.0), Some(-1e-300), None],
                    optimized: vec![None, Some(1.5), Some(2.0)],
                },
                FitColumns {
                    variable: "der(y)".into(),
                    unit: None,
                    measured: vec![3.0, 4.0, 5.0],
                    nominal: vec![Some(0.0); 3],
                    optimized: vec![Some(1.0); 3],
                },
            ],
        };
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("fit.csv"), fit_csv(&fit)).unwrap();
        let text = std::fs::read_to_string(dir.path().join("fit.csv")).unwrap();
        assert!(text.starts_with(
            "time,x:measured,x:start,x:optimized,der(y):measured,der(y):start,der(y):optimized\n0,1,2,,3,0,1\n0.5,,"
        ));
        let back = read_fit(&dir.path().join("fit.csv")).unwrap();
        assert_eq!(back.time, fit.time);
        assert_eq!(back.outputs[0].nominal, fit.outputs[0].nominal);
        assert_eq!(back.outputs[0].optimized, fit.outputs[0].optimized);
        assert!(back.outputs[0].measured[1].is_nan());
        assert_eq!(back.outputs[0].measured[2], 0.1 + 0.2);
        assert_eq!(back.outputs[1], fit.outputs[1]);
    }

    #[test]
    fn a_fit_csv_with_the_old_nominal_columns_is_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("fit.csv");
        std::fs::write(&path, "time,x:measured,x:nominal,x:optimized\n0,1,2,3\n").unwrap();
        let back = read_fit(&path).unwrap();
        assert_eq!(
            (back.outputs[0].nominal.as_slice(), back.outputs[0].optimized.as_slice()),
            (&[Some(2.0)][..], &[Some(3.0)][..])
        );
    }

    #[test]
    fn a_malformed_fit_csv_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("fit.csv");
        for text in [
            "time,x:measured,x:start\n0,1,2\n",
            "time,x:measured,x:nominl,x:optimized\n0,1,2,3\n",
            "t,x:measured,x:nominal,x:optimized\n",
            "time,x:measured,x:nominal,x:optimized\n0,1,two,3\n",
        ] {
            std::fs::write(&path, text).unwrap();
            assert!(read_fit(&path).is_err(), "{text}");
        }
    }
}
