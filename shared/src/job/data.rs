//! Measurement data: a time column and named columns, read from CSV (empty or `NaN` cells are
//! missing values) or from a MATLAB v5 `.mat` file (each real numeric array is a column named
//! after its variable, as the paper's `FurutaData.mat` with `time`, `phi` and `theta`).

use std::path::Path;

use super::JobError;

/// Measured signals; NaN marks a missing value.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MeasurementTable {
    pub time: Vec<f64>,
    pub columns: Vec<(String, Vec<f64>)>,
}

fn read_err(path: &Path, message: impl Into<String>) -> JobError {
    JobError::Read { path: path.display().to_string(), message: message.into() }
}

impl MeasurementTable {
    /// Reads `.mat` (MATLAB v5) or anything else as CSV.
    ///
    /// # Errors
    /// [`JobError::Read`] for unreadable files, a missing time column or non-numeric cells.
    pub fn read(path: &Path, time_column: &str) -> Result<Self, JobError> {
        match path.extension().and_then(|e| e.to_str()) {
            Some(ext) if ext.eq_ignore_ascii_case("mat") => Self::read_mat(path, time_column),
            _ => Self::read_csv(path, time_column),
        }
    }

    /// Reads a CSV file with a header row.
    ///
    /// # Errors
    /// See [`MeasurementTable::read`].
    pub fn read_csv(path: &Path, time_column: &str) -> Result<Self, JobError> {
        let mut reader = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .flexible(true)
            .from_path(path)
            .map_err(|e| read_err(path, e.to_string()))?;
        let headers: Vec<String> =
            reader.headers().map_err(|e| read_err(path, e.to_string()))?.iter().map(String::from).collect();
        let t = headers
            .iter()
            .position(|h| h == time_column)
            .ok_or_else(|| read_err(path, format!("no column named {time_column:?}")))?;
        let mut time = vec![];
        let mut columns: Vec<(String, Vec<f64>)> = headers.iter().map(|h| (h.clone(), vec![])).collect();
        for (row, rec) in reader.records().enumerate() {
            let line = row + 2;
            let rec = rec.map_err(|e| read_err(path, format!("line {line}: {e}")))?;
            if rec.len() != headers.len() {
                return Err(read_err(path, format!("line {line}: {} cells for {} columns", rec.len(), headers.len())));
            }
            for (i, cell) in rec.iter().enumerate() {
                let v = if cell.is_empty() {
                    f64::NAN
                } else {
                    cell.parse::<f64>().map_err(|_| {
                        read_err(path, format!("line {line}, column {:?}: {cell:?} is not a number", headers[i]))
                    })?
                };
                columns[i].1.push(v);
            }
        }
        time.append(&mut columns[t].1);
        columns.remove(t);
        Ok(MeasurementTable { time, columns })
    }

    /// Reads a MATLAB v5 file: the time variable and every other real numeric array.
    ///
    /// # Errors
    /// See [`MeasurementTable::read`].
    pub fn read_mat(path: &Path, time_column: &str) -> Result<Self, JobError> {
        let file = std::fs::File::open(path).map_err(|e| read_err(path, e.to_string()))?;
        let mat = matfile::MatFile::parse(std::io::BufReader::new(file))
            .map_err(|e| read_err(path, format!("not a MATLAB v5 file: {e:?}")))?;
        let as_f64 = |a: &matfile::Array| -> Option<Vec<f64>> {
            use matfile::NumericData::*;
            Some(match a.data() {
                Double { real, imag: None } => real.clone(),
                Single { real, imag: None } => real.iter().map(|&v| v as f64).collect(),
                Int32 { real, imag: None } => real.iter().map(|&v| v as f64).collect(),
                Int64 { real, imag: None } => real.iter().map(|&v| v as f64).collect(),
                _ => return None,
            })
        };
        let time_arr = mat
            .find_by_name(time_column)
            .ok_or_else(|| read_err(path, format!("no variable named {time_column:?}")))?;
        let time =
            as_f64(time_arr).ok_or_else(|| read_err(path, format!("{time_column:?} is not a real numeric array")))?;
        let columns = mat
            .arrays()
            .iter()
            .filter(|a| a.name() != time_column)
            .filter_map(|a| as_f64(a).map(|v| (a.name().to_owned(), v)))
            .collect();
        Ok(MeasurementTable { time, columns })
    }

    /// The values of a column.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.columns.iter().find(|(n, _)| n == name).map(|(_, v)| v.as_slice())
    }

    /// Checks the time column and the named columns: rows present, finite non-decreasing time,
    /// lengths matching.
    ///
    /// # Errors
    /// [`JobError::Invalid`] with field `data`, `data.time` or `data.columns[NAME]`.
    pub fn validate(&self, used: &[&str]) -> Result<(), JobError> {
        if self.time.is_empty() {
            return Err(JobError::invalid("data", "no rows"));
        }
        for (i, t) in self.time.iter().enumerate() {
            if !t.is_finite() {
                return Err(JobError::invalid("data.time", format!("row {} is not a finite number", i + 1)));
            }
            if i > 0 && *t < self.time[i - 1] {
                return Err(JobError::invalid(
                    "data.time",
                    format!("not monotonic: row {} has t={t} after t={}", i + 1, self.time[i - 1]),
                ));
            }
        }
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
        }
        Ok(())
    }
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
        t.validate(&["y"]).unwrap();
        assert!(t.validate(&["z"]).unwrap_err().to_string().starts_with("data.columns[z]"));
    }

    #[test]
    fn bad_tables_name_the_problem() {
        let t = MeasurementTable { time: vec![0.0, 2.0, 1.0], columns: vec![("y".into(), vec![0.0; 3])] };
        assert!(t.validate(&["y"]).unwrap_err().to_string().contains("not monotonic"));
        let t = MeasurementTable { time: vec![0.0, 1.0], columns: vec![("y".into(), vec![0.0; 3])] };
        assert!(t.validate(&["y"]).unwrap_err().to_string().contains("3 values for 2 time stamps"));
        assert!(MeasurementTable::default().validate(&[]).unwrap_err().to_string().contains("no rows"));
    }
}
