//! Measurement data: a [`TimeSeries`] whose NaN values are missing measurements, read by
//! [`crate::series::read`] from CSV (`,`, `;` or tab separated; empty or `NaN` cells are
//! missing, the time column may stand anywhere and be named in any case when only one column
//! is) or from a MATLAB `.mat` file (v5, or v4 as Dymola and OpenModelica write results, whose
//! variables are columns by name), and the checks a job makes of it.

use std::path::Path;

use super::JobError;
use crate::quote::quote_user_text;
use crate::series::{self, Layout, Missing, SeriesError, TimeColumn, TimeFault, TimeSeries};

/// Measured signals; NaN marks a missing value. The name the job's users (the gRPC conversion,
/// the CLI, tests) build and read tables by.
pub type MeasurementTable = TimeSeries;

impl TimeSeries {
    /// Reads measurements: `.mat` (MATLAB v5) or anything else as CSV, the time column named
    /// `time_column`, empty cells missing.
    ///
    /// # Errors
    /// [`JobError::Read`] for unreadable files, a missing time column or non-numeric cells.
    pub fn read(path: &Path, time_column: &str) -> Result<Self, JobError> {
        Self::read_selected(path, time_column, None).map(|s| s.table)
    }

    /// As [`Self::read`], keeping of a MATLAB v4 result file only the variables in `wanted`
    /// ([`series::read_selected`]), and giving the name of every column of the file.
    ///
    /// # Errors
    /// As [`Self::read`].
    pub fn read_selected(
        path: &Path,
        time_column: &str,
        wanted: Option<&[&str]>,
    ) -> Result<series::Selected, JobError> {
        let layout = Layout { time: TimeColumn::Named(time_column), missing: Missing::Allowed };
        series::read_selected(path, &layout, super::limits::MAX_DATA_FILE_BYTES, wanted).map_err(read_error)
    }

    /// Checks the time column and the named columns: no more than the caps
    /// ([`super::limits::check_table`]), rows present, finite non-decreasing time, lengths
    /// matching, and every value finite or missing (NaN).
    ///
    /// # Errors
    /// [`JobError::Invalid`] with field `data`, `data.time`, `data.columns` (a name given twice)
    /// or `data.columns[NAME]`.
    pub fn validate_measurements(&self, used: &[&str]) -> Result<(), JobError> {
        super::limits::check_table("data", self.time.len(), self.columns.len())?;
        if let Some(name) = self.duplicate_column() {
            return Err(JobError::invalid("data.columns", format!("column {} appears twice", quote_user_text(name))));
        }
        self.check_time().map_err(|fault| match fault {
            TimeFault::NoRows => JobError::invalid("data", "no rows"),
            _ => JobError::invalid("data.time", fault.to_string()),
        })?;
        for name in used {
            let col = self
                .column(name)
                .ok_or_else(|| JobError::invalid(format!("data.columns[{name}]"), "no such column"))?;
            if col.len() != self.time.len() {
                return Err(JobError::invalid(
                    format!("data.columns[{name}]"),
                    format!("{} values for {} time stamps", col.len(), self.time.len()),
                ));
            }
            if let Some(row) = col.iter().position(|v| v.is_infinite()) {
                return Err(JobError::invalid(
                    format!("data.columns[{name}]"),
                    format!(
                        "the value at time {} is {}: a measurement must be finite (leave the cell empty for a missing one)",
                        self.time[row], col[row]
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// Reads the data of each experiment of `spec` ([`super::JobSpec::experiment_views`]) from its
/// file; experiments that share the job's file share one read.
///
/// # Errors
/// [`JobError::Invalid`] naming `data` (or `experiments[K].data`) when there is no path, and
/// `data.path` when it is not a regular file or is over [`super::limits::MAX_DATA_FILE_BYTES`];
/// else as [`TimeSeries::read`].
pub fn read_all(spec: &super::JobSpec) -> Result<Vec<MeasurementTable>, JobError> {
    type Key = (std::path::PathBuf, String, Vec<String>);
    let mut read: Vec<(Key, series::Selected)> = vec![];
    let mut out = vec![];
    for view in spec.experiment_views() {
        let d = &view.spec.data;
        let path = d.path.clone().ok_or_else(|| {
            JobError::invalid(format!("{}data", view.field_prefix), "give the path of the measurements")
        })?;
        // Only a `.mat` file is read in part (a v4 result file): other files are read once
        // whatever their experiments use.
        let mat = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("mat"));
        let mut wanted: Vec<String> =
            if mat { used_columns(&view.spec).map(|(_, c)| c.to_owned()).collect() } else { vec![] };
        wanted.sort_unstable();
        wanted.dedup();
        let key = (path, d.time_column.clone(), wanted);
        let selected = match read.iter().find(|(k, _)| *k == key) {
            Some((_, s)) => s.clone(),
            None => {
                let field = format!("{}data.path", view.field_prefix);
                super::limits::check_regular_file(&field, &key.0, super::limits::MAX_DATA_FILE_BYTES)?;
                let wanted: Vec<&str> = key.2.iter().map(String::as_str).collect();
                let s = MeasurementTable::read_selected(&key.0, &key.1, mat.then_some(&wanted[..]))?;
                read.push((key, s.clone()));
                s
            }
        };
        check_columns(&view.spec, &view.field_prefix, selected.names.iter().map(String::as_str))?;
        out.push(selected.table);
    }
    Ok(out)
}

/// The data columns `spec` maps, each with the field that names it (`outputs[K].column`,
/// `inputs[K].column`).
fn used_columns(spec: &super::JobSpec) -> impl Iterator<Item = (String, &str)> {
    let outputs = spec.outputs.iter().enumerate().map(|(k, o)| (format!("outputs[{k}].column"), o.column.as_str()));
    let inputs = spec.inputs.iter().enumerate().map(|(k, i)| (format!("inputs[{k}].column"), i.column.as_str()));
    outputs.chain(inputs)
}

/// Checks that every column `spec` maps is among `names`, the data's columns.
///
/// # Errors
/// [`JobError::Invalid`] naming the field (after `prefix`), the column, and the (at most five)
/// columns of the data closest to it by edit distance.
pub fn check_columns<'a>(
    spec: &super::JobSpec,
    prefix: &str,
    names: impl IntoIterator<Item = &'a str>,
) -> Result<(), JobError> {
    let names: Vec<&str> = names.into_iter().collect();
    let present: std::collections::HashSet<&str> = names.iter().copied().collect();
    for (field, column) in used_columns(spec) {
        if present.contains(column) {
            continue;
        }
        let near: Vec<String> =
            series::closest(column, names.iter().copied(), 5).into_iter().map(quote_user_text).collect();
        let hint = if near.is_empty() {
            "; the data hold no column but time".to_owned()
        } else {
            format!("; the closest: {}", near.join(", "))
        };
        return Err(JobError::invalid(
            format!("{prefix}{field}"),
            format!("no column {} in the data{hint}", quote_user_text(column)),
        ));
    }
    Ok(())
}

/// A reader's error as the job reports it: `cannot read PATH: line N: ...`.
fn read_error(e: SeriesError) -> JobError {
    let message = match e.line {
        Some(line) => format!("line {line}: {}", e.message),
        None => e.message,
    };
    JobError::Read { path: e.path.display().to_string(), message }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::series::file;

    #[test]
    fn csv_empty_cells_are_missing_and_time_may_be_anywhere() {
        let dir = tempfile::tempdir().unwrap();
        let p = file(&dir, "d.csv", "y,time\n1.5,0\n,1\nNaN,2\n");
        let t = MeasurementTable::read(&p, "time").unwrap();
        assert_eq!(t.time, vec![0.0, 1.0, 2.0]);
        let y = t.column("y").unwrap();
        assert!(y[0] == 1.5 && y[1].is_nan() && y[2].is_nan());
        t.validate_measurements(&["y"]).unwrap();
        assert!(t.validate_measurements(&["z"]).unwrap_err().to_string().starts_with("data.columns[z]"));
    }

    #[test]
    fn read_errors_name_the_file_and_line() {
        let dir = tempfile::tempdir().unwrap();
        let p = file(&dir, "d.csv", "time,y\n0,1\n1,x\n");
        let e = MeasurementTable::read(&p, "time").unwrap_err().to_string();
        assert_eq!(e, format!("cannot read {}: line 3: column \"y\": \"x\" is not a number", p.display()));
        let e = MeasurementTable::read(&p, "t").unwrap_err().to_string();
        assert_eq!(
            e,
            format!("cannot read {}: line 1: no column named \"t\"; the closest: \"y\", \"time\"", p.display())
        );
    }

    #[test]
    fn data_paths_that_are_not_regular_files_or_too_large_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let job = |path: &str| {
            let text = crate::job::spec::tests::JOB.replace("path = \"d.csv\"", &format!("path = \"{path}\""));
            crate::job::JobSpec::from_toml(&text, dir.path()).unwrap()
        };
        let e = read_all(&job("/dev/zero")).unwrap_err().to_string();
        assert_eq!(e, "data.path: \"/dev/zero\" is a character device, not a regular file");
        let e = read_all(&job(".")).unwrap_err().to_string();
        assert!(e.starts_with("data.path: ") && e.ends_with("is a directory, not a regular file"), "{e}");
        std::fs::write(dir.path().join("d.csv"), "time,y\n0,1\n").unwrap();
        assert_eq!(read_all(&job("d.csv")).unwrap()[0].time, [0.0]);
        let e = super::super::limits::check_regular_file("data.path", &dir.path().join("d.csv"), 5).unwrap_err();
        assert!(e.to_string().ends_with("d.csv\" is 11 bytes, which exceeds the cap of 5"), "{e}");
    }

    #[test]
    fn bad_tables_name_the_problem() {
        let t = MeasurementTable { time: vec![0.0, 2.0, 1.0], columns: vec![("y".into(), vec![0.0; 3])] };
        assert!(t.validate_measurements(&["y"]).unwrap_err().to_string().contains("not monotonic"));
        let t = MeasurementTable { time: vec![0.0, 1.0], columns: vec![("y".into(), vec![0.0; 3])] };
        assert!(t.validate_measurements(&["y"]).unwrap_err().to_string().contains("3 values for 2 time stamps"));
        assert!(MeasurementTable::default().validate_measurements(&[]).unwrap_err().to_string().contains("no rows"));
        // A table built from a request (no CSV header to check) names each column once too.
        let t = MeasurementTable {
            time: vec![0.0, 1.0],
            columns: vec![("y".into(), vec![0.0; 2]), ("z".into(), vec![0.0; 2]), ("y".into(), vec![1.0; 2])],
        };
        assert_eq!(
            t.validate_measurements(&["z"]).unwrap_err().to_string(),
            "data.columns: column \"y\" appears twice"
        );
        let t = MeasurementTable { time: vec![0.0, 1.0], columns: vec![("y".into(), vec![0.0, f64::INFINITY])] };
        let e = t.validate_measurements(&["y"]).unwrap_err().to_string();
        assert!(e.starts_with("data.columns[y]: the value at time 1 is inf"), "{e}");
    }
}
