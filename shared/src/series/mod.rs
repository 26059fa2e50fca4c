//! The one time-series type of fmucal: a time column and named columns of samples, for
//! simulation inputs and measurement data alike, read from CSV or MATLAB v5 files by [`read`].
//! This module owns the table, its column lookup and the check of its time column; what the
//! samples mean belongs to their users: [`crate::sim::inputs`] validates and interpolates
//! inputs, [`crate::job::data`] checks measurements (where NaN marks a missing value).
//! [`write_csv`] writes a table that reads back exactly.

mod mat4;
mod read;
mod write;

/// Tests write their files with it.
#[cfg(test)]
pub(crate) use read::tests::file;
pub use read::{
    Layout, MAX_FILE_BYTES, Missing, Selected, SeriesError, TimeColumn, read, read_capped, read_csv, read_csv_capped,
    read_mat, read_selected,
};
pub use write::write_csv;

/// Values (rows × columns) one table read from a file may hold: 800 MB of numbers. The jobs'
/// measurement tables have the same cap (`job::limits::MAX_DATA_VALUES`).
pub const MAX_VALUES: usize = 100_000_000;

/// Samples of named signals at common time stamps.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TimeSeries {
    pub time: Vec<f64>,
    /// (column name, samples aligned with `time`).
    pub columns: Vec<(String, Vec<f64>)>,
}

/// What is wrong with a time column; rows count from 1.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum TimeFault {
    #[error("no rows")]
    NoRows,
    #[error("row {row} is not a finite number")]
    NotFinite { row: usize },
    #[error("not monotonic: row {row} has t={t} after t={previous}")]
    Decreasing { row: usize, t: f64, previous: f64 },
}

/// Up to `n` of `names` closest to `name` by edit distance (case-insensitive, over at most the
/// first 64 characters of each), closest first, ties in their order: the hint of an error that
/// names a column the data lack.
pub fn closest<'a>(name: &str, names: impl IntoIterator<Item = &'a str>, n: usize) -> Vec<&'a str> {
    let key = |s: &str| s.chars().take(64).flat_map(char::to_lowercase).collect::<Vec<char>>();
    let target = key(name);
    let mut scored: Vec<(usize, usize, &str)> =
        names.into_iter().enumerate().map(|(i, c)| (edit_distance(&target, &key(c)), i, c)).collect();
    scored.sort_unstable();
    scored.into_iter().take(n).map(|(_, _, c)| c).collect()
}

/// The Levenshtein distance between `a` and `b`.
fn edit_distance(a: &[char], b: &[char]) -> usize {
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.iter().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let next = (row[j + 1] + 1).min(row[j] + 1).min(diagonal + usize::from(ca != cb));
            diagonal = row[j + 1];
            row[j + 1] = next;
        }
    }
    row[b.len()]
}

/// The first name that appears twice among `names`: a file's header or a table's columns,
/// which must name each column once (the one check the CSV reader and the protocol share).
pub fn first_duplicate<'a>(names: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let mut seen = std::collections::HashSet::new();
    names.into_iter().find(|n| !seen.insert(*n))
}

impl TimeSeries {
    /// The name of the first column named twice, if any.
    pub fn duplicate_column(&self) -> Option<&str> {
        first_duplicate(self.columns.iter().map(|(n, _)| n.as_str()))
    }

    /// The values of the column named `name` (the first, if several are).
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.columns.iter().find(|(n, _)| n == name).map(|(_, v)| v.as_slice())
    }

    /// Checks the time column: at least one row, every time finite, none before the one above.
    ///
    /// # Errors
    /// The first [`TimeFault`], in row order.
    pub fn check_time(&self) -> Result<(), TimeFault> {
        if self.time.is_empty() {
            return Err(TimeFault::NoRows);
        }
        for (i, &t) in self.time.iter().enumerate() {
            if !t.is_finite() {
                return Err(TimeFault::NotFinite { row: i + 1 });
            }
            if i > 0 && t < self.time[i - 1] {
                return Err(TimeFault::Decreasing { row: i + 1, t, previous: self.time[i - 1] });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_faults_name_the_first_bad_row() {
        let series = |time: Vec<f64>| TimeSeries { time, columns: vec![] };
        assert_eq!(series(vec![]).check_time(), Err(TimeFault::NoRows));
        assert_eq!(series(vec![0.0, 1.0, 1.0]).check_time(), Ok(()));
        assert_eq!(series(vec![0.0, f64::INFINITY, -1.0]).check_time(), Err(TimeFault::NotFinite { row: 2 }));
        let fault = series(vec![0.0, 2.0, 1.0]).check_time().unwrap_err();
        assert_eq!(fault.to_string(), "not monotonic: row 3 has t=1 after t=2");
    }

    #[test]
    fn column_finds_by_name() {
        let t = TimeSeries { time: vec![0.0], columns: vec![("a".into(), vec![1.0]), ("b".into(), vec![2.0])] };
        assert_eq!(t.column("b"), Some(&[2.0][..]));
        assert_eq!(t.column("c"), None);
    }
}
