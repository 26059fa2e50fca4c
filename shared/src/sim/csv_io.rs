//! CSV in and out, in the layout FMPy writes: a header row, the first column `time`, then one
//! column per variable.

use std::io::Write;
use std::path::{Path, PathBuf};

use super::inputs::InputTable;
use super::spec::SimResult;

/// A CSV file that could not be read or written.
#[derive(Debug, thiserror::Error)]
#[error("{path}{}: {message}", .line.map(|l| format!(" line {l}")).unwrap_or_default())]
pub struct CsvError {
    pub path: PathBuf,
    pub line: Option<u64>,
    pub message: String,
}

fn err(path: &Path, line: Option<u64>, message: impl Into<String>) -> CsvError {
    CsvError { path: path.to_owned(), line, message: message.into() }
}

/// Reads a table whose first column is `time`. Every cell must be a number; `nan` is read as
/// NaN and rejected later by validation with the column named.
///
/// # Errors
/// [`CsvError`] naming the line and column of a missing or non-numeric cell.
pub fn read_table(path: &Path) -> Result<InputTable, CsvError> {
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .flexible(true)
        .from_path(path)
        .map_err(|e| err(path, None, e.to_string()))?;
    let headers: Vec<String> =
        reader.headers().map_err(|e| err(path, Some(1), e.to_string()))?.iter().map(str::to_owned).collect();
    if headers.first().map(String::as_str) != Some("time") {
        return Err(err(path, Some(1), "the first column must be named \"time\""));
    }
    if let Some(dup) = headers.iter().enumerate().find(|(i, h)| headers[..*i].contains(h)) {
        return Err(err(path, Some(1), format!("column {:?} appears twice", dup.1)));
    }
    let mut time = vec![];
    let mut columns: Vec<(String, Vec<f64>)> = headers[1..].iter().map(|h| (h.clone(), vec![])).collect();
    for (row, record) in reader.records().enumerate() {
        let line = row as u64 + 2;
        let record = record.map_err(|e| err(path, Some(line), e.to_string()))?;
        if record.len() != headers.len() {
            let missing = headers.get(record.len()).map(|h| format!(", column {h:?} is missing")).unwrap_or_default();
            return Err(err(
                path,
                Some(line),
                format!("{} cells for {} columns{missing}", record.len(), headers.len()),
            ));
        }
        for (i, cell) in record.iter().enumerate() {
            let v: f64 = cell
                .parse()
                .map_err(|_| err(path, Some(line), format!("column {:?}: {cell:?} is not a number", headers[i])))?;
            if i == 0 {
                time.push(v);
            } else {
                columns[i - 1].1.push(v);
            }
        }
    }
    if time.is_empty() {
        return Err(err(path, None, "no data rows"));
    }
    Ok(InputTable { time, columns })
}

/// Reads output times from the first column of a CSV file (header row required).
///
/// # Errors
/// [`CsvError`] as [`read_table`].
pub fn read_times(path: &Path) -> Result<Vec<f64>, CsvError> {
    Ok(read_table(path)?.time)
}

/// Writes a result as CSV.
///
/// # Errors
/// [`CsvError`] if writing fails.
pub fn write_result(result: &SimResult, out: impl Write, path_for_errors: &Path) -> Result<(), CsvError> {
    let e = |x: csv::Error| err(path_for_errors, None, x.to_string());
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
    w.flush().map_err(|x| err(path_for_errors, None, x.to_string()))?;
    Ok(())
}
