//! Measurement data: a [`TimeSeries`] whose NaN values are missing measurements, read by
//! [`crate::series::read`] from CSV (empty or `NaN` cells are missing, the time column may
//! stand anywhere) or from a MATLAB v5 `.mat` file, and the checks a job makes of it.

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
        let layout = Layout { time: TimeColumn::Named(time_column), missing: Missing::Allowed };
        series::read_capped(path, &layout, super::limits::MAX_DATA_FILE_BYTES).map_err(read_error)
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
    let mut read: Vec<(std::path::PathBuf, String, MeasurementTable)> = vec![];
    let mut out = vec![];
    for view in spec.experiment_views() {
        let d = &view.spec.data;
        let path = d.path.clone().ok_or_else(|| {
            JobError::invalid(format!("{}data", view.field_prefix), "give the path of the measurements")
        })?;
        let table = match read.iter().find(|(p, c, _)| *p == path && *c == d.time_column) {
            Some((_, _, t)) => t.clone(),
            None => {
                let field = format!("{}data.path", view.field_prefix);
                super::limits::check_regular_file(&field, &path, super::limits::MAX_DATA_FILE_BYTES)?;
                let t = MeasurementTable::read(&path, &d.time_column)?;
                read.push((path, d.time_column.clone(), t.clone()));
                t
            }
        };
        out.push(table);
    }
    Ok(out)
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

    #[test]
    fn csv_empty_cells_are_missing_and_time_may_be_anywhere() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("d.csv");
        std::fs::write(&p, "y,time\n1.5,0\n,1\nNaN,2\n").unwrap();
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
        let p = dir.path().join("d.csv");
        std::fs::write(&p, "time,y\n0,1\n1,x\n").unwrap();
        let e = MeasurementTable::read(&p, "time").unwrap_err().to_string();
        assert_eq!(e, format!("cannot read {}: line 3: column \"y\": \"x\" is not a number", p.display()));
        let e = MeasurementTable::read(&p, "t").unwrap_err().to_string();
        assert_eq!(e, format!("cannot read {}: line 1: no column named \"t\"", p.display()));
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
