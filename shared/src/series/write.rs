//! Writes a [`TimeSeries`] as CSV that [`super::read`] reads back exactly: a header with the
//! time column first, every value in Rust's shortest round-trip form, NaN as an empty cell.

use std::path::Path;

use super::{SeriesError, TimeSeries};

/// Writes `series` to `path` with its time column named `time_column`.
///
/// # Errors
/// A column whose length is not the time column's, a column named `time_column`, or a write
/// failure.
pub fn write_csv(series: &TimeSeries, path: &Path, time_column: &str) -> Result<(), SeriesError> {
    let fail = |message: String| SeriesError::new(path, None, message);
    for (name, values) in &series.columns {
        if name == time_column {
            return Err(fail(format!("column {name:?} has the time column's name")));
        }
        if values.len() != series.time.len() {
            return Err(fail(format!(
                "column {name:?} has {} values for {} time stamps",
                values.len(),
                series.time.len()
            )));
        }
    }
    let mut w = csv::Writer::from_path(path).map_err(|e| fail(e.to_string()))?;
    let header = std::iter::once(time_column).chain(series.columns.iter().map(|(n, _)| n.as_str()));
    w.write_record(header).map_err(|e| fail(e.to_string()))?;
    let cell = |v: f64| if v.is_nan() { String::new() } else { v.to_string() };
    for (i, t) in series.time.iter().enumerate() {
        let row = std::iter::once(cell(*t)).chain(series.columns.iter().map(|(_, v)| cell(v[i])));
        w.write_record(row).map_err(|e| fail(e.to_string()))?;
    }
    w.flush().map_err(|e| fail(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::series::{Layout, Missing, TimeColumn, read};

    #[test]
    fn what_is_written_reads_back_exactly() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.csv");
        let series = TimeSeries {
            time: vec![0.0, 0.1, 0.30000000000000004, 1e-300],
            columns: vec![
                ("a, \"quoted\"".into(), vec![1.0 / 3.0, f64::NAN, -2.5e-17, 7.0]),
                ("b".into(), vec![f64::MAX, f64::MIN_POSITIVE, 0.0, -0.0]),
            ],
        };
        write_csv(&series, &path, "t").unwrap();
        let layout = Layout { time: TimeColumn::Named("t"), missing: Missing::Allowed };
        let back = read(&path, &layout).unwrap();
        assert_eq!(back.time, series.time);
        assert_eq!(back.columns.len(), 2);
        for ((n, v), (m, w)) in back.columns.iter().zip(&series.columns) {
            assert_eq!(n, m);
            for (x, y) in v.iter().zip(w) {
                assert!(x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()), "{x} vs {y}");
            }
        }
    }

    #[test]
    fn ragged_columns_and_a_clash_with_the_time_column_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.csv");
        let ragged = TimeSeries { time: vec![0.0, 1.0], columns: vec![("y".into(), vec![1.0])] };
        let e = write_csv(&ragged, &path, "time").unwrap_err();
        assert_eq!(e.message, "column \"y\" has 1 values for 2 time stamps");
        let clash = TimeSeries { time: vec![0.0], columns: vec![("time".into(), vec![1.0])] };
        assert!(write_csv(&clash, &path, "time").unwrap_err().message.contains("time column's name"));
    }
}
