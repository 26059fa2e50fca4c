//! CSV in and out, in the layout FMPy writes: a header row, the first column `time`, then one
//! column per variable.

use std::io::Write;
use std::path::Path;

use super::spec::SimResult;
use crate::series::{self, Layout, Missing, SeriesError, TimeColumn, TimeSeries};

/// FMPy's layout: `time` first, every cell a number.
const FMPY: Layout = Layout { time: TimeColumn::First("time"), missing: Missing::Refused };

/// Reads a table whose first column is `time`. Every cell must be a number; `nan` is read as
/// NaN and rejected later by validation with the column named.
///
/// # Errors
/// [`SeriesError`] naming the line and column of a missing or non-numeric cell.
pub fn read_table(path: &Path) -> Result<TimeSeries, SeriesError> {
    // Capped and a regular file only, as every file a user names (not `read_csv`: a `.mat`
    // name would read as CSV here either way, so the extension is set aside).
    series::read_csv_capped(path, &FMPY, series::MAX_FILE_BYTES)
}

/// Reads output times from the first column of a CSV file (header row required).
///
/// # Errors
/// [`SeriesError`] as [`read_table`].
pub fn read_times(path: &Path) -> Result<Vec<f64>, SeriesError> {
    Ok(read_table(path)?.time)
}

/// Writes a result as CSV.
///
/// # Errors
/// [`SeriesError`] if writing fails.
pub fn write_result(result: &SimResult, out: impl Write, path_for_errors: &Path) -> Result<(), SeriesError> {
    let e = |x: csv::Error| SeriesError::new(path_for_errors, None, x.to_string());
    let mut w = csv::Writer::from_writer(out);
    let mut header = vec!["time".to_owned()];
    header.extend(result.names.iter().cloned());
    w.write_record(&header).map_err(e)?;
    let mut row: Vec<String> = Vec::with_capacity(header.len());
    for (i, t) in result.time.iter().enumerate() {
        row.clear();
        row.push(format!("{t}"));
        row.extend(result.columns.iter().map(|c| format!("{}", c[i])));
        w.write_record(&row).map_err(e)?;
    }
    w.flush().map_err(|x| SeriesError::new(path_for_errors, None, x.to_string()))?;
    Ok(())
}
