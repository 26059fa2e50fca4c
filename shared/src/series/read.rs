//! The one reader of time-series files: CSV with a header row (separated by `,`, `;` or tab,
//! whichever the header holds most of), MATLAB v5 `.mat` where every real numeric array is a
//! column named after its variable (as the paper's `FurutaData.mat` with `time`, `phi` and
//! `theta`), or MATLAB v4 `.mat`, a Modelica result file (Dymola's `dsres.mat`,
//! OpenModelica's `_res.mat`: every variable a column, aliases included) or plain matrices
//! ([`super::mat4`]). A [`Layout`] carries what differs between callers: where the time column
//! stands, and whether an empty cell is a missing value or an error.
//!
//! The time column is found by its name; when no column has exactly that name but exactly one
//! has it in another case (`Time` for `time`, as Dymola names it), that one is time.

use std::path::{Path, PathBuf};

use super::TimeSeries;
use crate::quote::quote_user_text;

/// Where the time column stands in a CSV file. In a `.mat` file, the variable of that name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TimeColumn<'a> {
    /// First, and named so (the layout FMPy reads and writes).
    First(&'a str),
    /// Anywhere, named so.
    Named(&'a str),
}

impl TimeColumn<'_> {
    /// The time column's name.
    pub fn name(&self) -> &str {
        match self {
            TimeColumn::First(name) | TimeColumn::Named(name) => name,
        }
    }
}

/// What an empty CSV cell means. A `NaN` cell reads as NaN either way: the caller's checks
/// refuse it where it is not a missing value, naming its column and row.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Missing {
    /// A missing value, read as NaN (measurements).
    Allowed,
    /// An error naming the line and column (inputs).
    Refused,
}

/// How to read a file: the time column and the meaning of empty cells.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout<'a> {
    pub time: TimeColumn<'a>,
    pub missing: Missing,
}

/// A time-series file that could not be read or written; `line` is the CSV line at fault.
#[derive(Debug, thiserror::Error)]
#[error("{path}{}: {message}", .line.map(|l| format!(" line {l}")).unwrap_or_default())]
pub struct SeriesError {
    pub path: PathBuf,
    pub line: Option<u64>,
    pub message: String,
}

impl SeriesError {
    pub fn new(path: &Path, line: Option<u64>, message: impl Into<String>) -> Self {
        SeriesError { path: path.to_owned(), line, message: message.into() }
    }
}

/// Reads `.mat` (MATLAB v5, any case of the extension) or anything else as CSV.
///
/// # Errors
/// See [`read_csv`] and [`read_mat`].
pub fn read(path: &Path, layout: &Layout) -> Result<TimeSeries, SeriesError> {
    read_capped(path, layout, MAX_FILE_BYTES)
}

/// Bytes a time-series file given on the command line or in a job is read up to
/// ([`read_capped`]): 4 GiB, past the 10⁸ values a measurement table may hold.
pub const MAX_FILE_BYTES: u64 = 4 << 30;

/// As [`read`], for a regular file (a device, a FIFO or a folder is refused before it is
/// opened: `/dev/zero` never ends, and opening a FIFO waits for a writer), reading no more
/// than `max_bytes` bytes of it: past them, the read fails (also for a file that grows).
///
/// # Errors
/// As [`read`], and a [`SeriesError`] saying what the path is, or the cap when the file holds
/// more.
pub fn read_capped(path: &Path, layout: &Layout, max_bytes: u64) -> Result<TimeSeries, SeriesError> {
    read_selected(path, layout, max_bytes, None).map(|s| s.table)
}

/// A table read by [`read_selected`] and the name of every column its file holds.
#[derive(Debug, Clone)]
pub struct Selected {
    pub table: TimeSeries,
    /// Every column of the file but time, those left out of `table` too.
    pub names: Vec<String>,
}

/// As [`read_capped`], keeping of a MATLAB v4 file only the time and the variables named in
/// `wanted` (a Modelica result file holds thousands; all of them would not fit the caps).
/// Other formats keep every column.
///
/// # Errors
/// As [`read_capped`].
pub fn read_selected(
    path: &Path,
    layout: &Layout,
    max_bytes: u64,
    wanted: Option<&[&str]>,
) -> Result<Selected, SeriesError> {
    let capped = open_capped(path, max_bytes)?;
    let mat = path.extension().and_then(|e| e.to_str()).is_some_and(|ext| ext.eq_ignore_ascii_case("mat"));
    let result = if mat {
        mat_from(path, capped, layout.time.name(), wanted)
    } else {
        csv_from(path, capped, layout).map(|table| {
            let names = table.columns.iter().map(|(n, _)| n.clone()).collect();
            Selected { table, names }
        })
    };
    result.map_err(|e| said_cap(path, e, max_bytes))
}

/// As [`read_capped`], reading CSV whatever the file's name.
///
/// # Errors
/// As [`read_capped`].
pub fn read_csv_capped(path: &Path, layout: &Layout, max_bytes: u64) -> Result<TimeSeries, SeriesError> {
    let capped = open_capped(path, max_bytes)?;
    csv_from(path, capped, layout).map_err(|e| said_cap(path, e, max_bytes))
}

/// Opens `path` for [`read_capped`]: a regular file, of at most `max_bytes` as far as its size
/// says, read through a [`Capped`] reader.
fn open_capped(path: &Path, max_bytes: u64) -> Result<Capped<std::fs::File>, SeriesError> {
    let meta = std::fs::metadata(path).map_err(|e| SeriesError::new(path, None, e.to_string()))?;
    if let Some(kind) = crate::fmu::archive::non_regular_kind(&meta) {
        return Err(SeriesError::new(path, None, format!("it is {kind}, not a regular file")));
    }
    let file = std::fs::File::open(path).map_err(|e| SeriesError::new(path, None, e.to_string()))?;
    if file.metadata().is_ok_and(|m| m.len() > max_bytes) {
        return Err(SeriesError::new(path, None, format!("{CAPPED} {max_bytes} bytes")));
    }
    Ok(Capped { inner: file, left: max_bytes })
}

/// A reader's error, or the cap when the [`Capped`] reader stopped it.
fn said_cap(path: &Path, e: SeriesError, max_bytes: u64) -> SeriesError {
    if e.message.contains(CAPPED) { SeriesError::new(path, None, format!("{CAPPED} {max_bytes} bytes")) } else { e }
}

/// What a [`Capped`] reader says past its cap.
const CAPPED: &str = "the file exceeds the cap of";

/// A reader that fails once more than `left` bytes are asked of it.
struct Capped<R> {
    inner: R,
    left: u64,
}

impl<R: std::io::Read> std::io::Read for Capped<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.left == 0 {
            // At the cap: fine if the file ends here, an error if it holds more.
            let mut probe = [0u8; 1];
            return match self.inner.read(&mut probe)? {
                0 => Ok(0),
                _ => Err(std::io::Error::other(CAPPED)),
            };
        }
        let n = buf.len().min(usize::try_from(self.left).unwrap_or(usize::MAX));
        let got = self.inner.read(&mut buf[..n])?;
        self.left -= got as u64;
        Ok(got)
    }
}

/// Reads a CSV file with a header row; cells are trimmed.
///
/// # Errors
/// [`SeriesError`] for an unreadable file, a time column missing or out of place, a column
/// named twice, a row with too few or too many cells, a cell that is not a number (an empty
/// one too, unless [`Missing::Allowed`]) or no data rows, naming the line where there is one.
pub fn read_csv(path: &Path, layout: &Layout) -> Result<TimeSeries, SeriesError> {
    let file = std::fs::File::open(path).map_err(|e| SeriesError::new(path, None, e.to_string()))?;
    csv_from(path, file, layout)
}

/// The delimiter of a CSV file whose first line is `header`: `,`, `;` or tab, whichever it
/// holds most of outside quotes (`,` when it holds none, a one-column file).
fn delimiter(header: &[u8]) -> u8 {
    let mut counts = [0usize; 3];
    let mut quoted = false;
    for &b in header {
        match b {
            b'"' => quoted = !quoted,
            b',' if !quoted => counts[0] += 1,
            b';' if !quoted => counts[1] += 1,
            b'\t' if !quoted => counts[2] += 1,
            _ => {}
        }
    }
    let best = (0..3).max_by_key(|&i| (counts[i], std::cmp::Reverse(i))).unwrap_or(0);
    if counts[best] == 0 { b',' } else { [b',', b';', b'\t'][best] }
}

/// Bytes of the first line [`csv_from`] looks at for the delimiter.
const MAX_HEADER_PEEK: u64 = 1 << 20;

/// [`read_csv`] from an open reader of `path`.
fn csv_from(path: &Path, source: impl std::io::Read, layout: &Layout) -> Result<TimeSeries, SeriesError> {
    use std::io::{BufRead, Read};
    let mut source = std::io::BufReader::new(source);
    let mut first = vec![];
    (&mut source)
        .take(MAX_HEADER_PEEK)
        .read_until(b'\n', &mut first)
        .map_err(|e| SeriesError::new(path, None, e.to_string()))?;
    let separator = delimiter(&first);
    let source = std::io::Cursor::new(first).chain(source);
    let mut reader =
        csv::ReaderBuilder::new().delimiter(separator).trim(csv::Trim::All).flexible(true).from_reader(source);
    let header_err = |message: String| SeriesError::new(path, Some(1), message);
    let headers: Vec<String> =
        reader.headers().map_err(|e| header_err(e.to_string()))?.iter().map(str::to_owned).collect();
    let t = time_index(&headers, layout.time).map_err(header_err)?;
    if let Some(dup) = super::first_duplicate(headers.iter().map(String::as_str)) {
        return Err(header_err(format!("column {} appears twice", quote_user_text(dup))));
    }
    let mut values: Vec<Vec<f64>> = vec![vec![]; headers.len()];
    for (row, record) in reader.records().enumerate() {
        let line = row as u64 + 2;
        let err = |message: String| SeriesError::new(path, Some(line), message);
        let record = record.map_err(|e| err(e.to_string()))?;
        if record.len() != headers.len() {
            let missing = headers
                .get(record.len())
                .map(|h| format!(", column {} is missing", quote_user_text(h)))
                .unwrap_or_default();
            return Err(err(format!("{} cells for {} columns{missing}", record.len(), headers.len())));
        }
        for ((cell, name), column) in record.iter().zip(&headers).zip(&mut values) {
            let v = parse_cell(cell, layout.missing, separator != b',').ok_or_else(|| {
                err(format!("column {}: {} is not a number", quote_user_text(name), quote_user_text(cell)))
            })?;
            column.push(v);
        }
    }
    let time = values.remove(t);
    if time.is_empty() {
        return Err(SeriesError::new(path, None, "no data rows"));
    }
    let names = headers.into_iter().enumerate().filter(|&(i, _)| i != t).map(|(_, h)| h);
    Ok(TimeSeries { time, columns: names.zip(values).collect() })
}

/// The position of the time column among `headers`, or why it has none.
fn time_index(headers: &[String], time: TimeColumn) -> Result<usize, String> {
    match time {
        TimeColumn::First(name) if headers.first().is_some_and(|h| h == name) => Ok(0),
        TimeColumn::First(name)
            if headers.first().is_some_and(|h| h.eq_ignore_ascii_case(name)) && !headers.iter().any(|h| h == name) =>
        {
            Ok(0)
        }
        TimeColumn::First(name) => Err(format!("the first column must be named {}", quote_user_text(name))),
        TimeColumn::Named(name) => find_time(headers, name),
    }
}

/// The position of the column named `name` among `names`: the one of that name, else the one
/// whose name differs from it in case only when exactly one does (`Time` for `time`).
///
/// # Errors
/// `no column named "NAME"`, with a hint at the columns that differ only in case if several
/// do.
pub(super) fn find_time(names: &[String], name: &str) -> Result<usize, String> {
    if let Some(i) = names.iter().position(|h| h == name) {
        return Ok(i);
    }
    let alike: Vec<usize> = (0..names.len()).filter(|&i| names[i].eq_ignore_ascii_case(name)).collect();
    match alike[..] {
        [i] => Ok(i),
        [] => {
            let near: Vec<String> =
                super::closest(name, names.iter().map(String::as_str), 5).into_iter().map(quote_user_text).collect();
            let hint = if near.is_empty() { String::new() } else { format!("; the closest: {}", near.join(", ")) };
            Err(format!("no column named {}{hint}", quote_user_text(name)))
        }
        _ => {
            let listed: Vec<String> = alike.iter().take(5).map(|&i| quote_user_text(&names[i])).collect();
            Err(format!("no column named {}; did you mean {}?", quote_user_text(name), listed.join(" or ")))
        }
    }
}

/// A cell's number; an empty cell is NaN if missing values are allowed. In a file not
/// separated by commas a decimal comma is read too (`1,5` as 1.5, as spreadsheets write with
/// `;`).
fn parse_cell(cell: &str, missing: Missing, decimal_comma: bool) -> Option<f64> {
    if cell.is_empty() && missing == Missing::Allowed {
        return Some(f64::NAN);
    }
    cell.parse().ok().or_else(|| {
        let once = decimal_comma && cell.matches(',').count() == 1 && !cell.contains('.');
        if once { cell.replace(',', ".").parse().ok() } else { None }
    })
}

/// Where a MATLAB v5 file's top-level data elements run past its end (or its 128-byte header
/// is incomplete), if they do.
fn mat_truncated_at(bytes: &[u8]) -> Option<usize> {
    if bytes.len() < 128 {
        return Some(bytes.len());
    }
    // The endian indicator "MI", written as a 16-bit number: "IM" in a little-endian file.
    let little = &bytes[126..128] == b"IM";
    let word = |at: usize| {
        let b = [bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]];
        if little { u32::from_le_bytes(b) } else { u32::from_be_bytes(b) }
    };
    let mut at = 128;
    while at < bytes.len() {
        if at + 8 > bytes.len() {
            return Some(at);
        }
        let (kind, size) = (word(at), word(at + 4) as usize);
        if kind >> 16 != 0 {
            // A small data element: its size is in the upper half of the first word.
            at += 8;
            continue;
        }
        let end = at + 8 + size;
        if end > bytes.len() {
            return Some(at);
        }
        // Elements are padded to 8 bytes, except compressed ones (type 15).
        at = if kind == 15 { end } else { end.next_multiple_of(8) };
    }
    None
}

/// Reads a MATLAB v5 file: the variable `time_column` as time and every other real numeric
/// array as a column (others, such as complex or character arrays, are left out).
///
/// # Errors
/// [`SeriesError`] for an unreadable, truncated or non-v5 file, a time variable missing, not real and
/// numeric, or empty.
pub fn read_mat(path: &Path, time_column: &str) -> Result<TimeSeries, SeriesError> {
    let file = std::fs::File::open(path).map_err(|e| SeriesError::new(path, None, e.to_string()))?;
    mat_from(path, file, time_column, None).map(|s| s.table)
}

/// [`read_mat`] from an open reader of `path`, a v4 file's columns limited to `wanted`.
fn mat_from(
    path: &Path,
    mut source: impl std::io::Read,
    time_column: &str,
    wanted: Option<&[&str]>,
) -> Result<Selected, SeriesError> {
    let err = |message: String| SeriesError::new(path, None, message);
    // Read once (the reader carries the size cap), then checked and parsed from memory.
    let mut bytes = vec![];
    source.read_to_end(&mut bytes).map_err(|e| err(e.to_string()))?;
    let v5 = bytes.starts_with(b"MATLAB") || bytes.get(126..128).is_some_and(|m| m == b"IM" || m == b"MI");
    if !v5 {
        if !super::mat4::looks_like_v4(&bytes) {
            return Err(err("neither a MATLAB v4 nor a v5 file".into()));
        }
        let r = super::mat4::read(&bytes, time_column, wanted).map_err(err)?;
        if r.time.is_empty() {
            return Err(err("no data rows".into()));
        }
        return Ok(Selected { table: TimeSeries { time: r.time, columns: r.columns }, names: r.names });
    }
    let mat = matfile::MatFile::parse(bytes.as_slice())
        .map_err(|_| err("not a MATLAB v5 file: its structure does not parse".into()))?;
    // A file cut short reads as one with fewer variables (or none): say so rather than name
    // a missing one, or silently lose some.
    if let Some(at) = mat_truncated_at(&bytes) {
        return Err(err(format!("truncated or invalid MATLAB v5 file: a data element runs past its end at byte {at}")));
    }
    let all: Vec<String> = mat.arrays().iter().map(|a| a.name().to_owned()).collect();
    let t = find_time(&all, time_column).map_err(|e| err(e.replace("column", "variable")))?;
    let time_name = all[t].as_str();
    let time = real_values(&mat.arrays()[t])
        .ok_or_else(|| err(format!("{} is not a real numeric array", quote_user_text(time_name))))?;
    if time.is_empty() {
        return Err(err("no data rows".into()));
    }
    let columns: Vec<(String, Vec<f64>)> = mat
        .arrays()
        .iter()
        .filter(|a| a.name() != time_name)
        .filter_map(|a| real_values(a).map(|v| (a.name().to_owned(), v)))
        .collect();
    let names = columns.iter().map(|(n, _)| n.clone()).collect();
    Ok(Selected { table: TimeSeries { time, columns }, names })
}

/// The values of a real double, single, int32 or int64 array, in storage order.
fn real_values(array: &matfile::Array) -> Option<Vec<f64>> {
    use matfile::NumericData::*;
    Some(match array.data() {
        Double { real, imag: None } => real.clone(),
        Single { real, imag: None } => real.iter().map(|&v| v as f64).collect(),
        Int32 { real, imag: None } => real.iter().map(|&v| v as f64).collect(),
        Int64 { real, imag: None } => real.iter().map(|&v| v as f64).collect(),
        _ => return None,
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    const INPUTS: Layout = Layout { time: TimeColumn::First("time"), missing: Missing::Refused };
    const MEASUREMENTS: Layout = Layout { time: TimeColumn::Named("time"), missing: Missing::Allowed };

    /// Writes file `name` in `dir` and gives its path.
    pub(crate) fn file(dir: &tempfile::TempDir, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }

    /// The error's line and message.
    fn fault(r: Result<TimeSeries, SeriesError>) -> (Option<u64>, String) {
        let e = r.unwrap_err();
        (e.line, e.message)
    }

    #[test]
    fn missing_cells_are_nan_when_allowed() {
        let dir = tempfile::tempdir().unwrap();
        let p = file(&dir, "d.csv", "y, time ,z\n1.5,0,1\n,1,2\nNaN,2,3\n");
        let t = read(&p, &MEASUREMENTS).unwrap();
        assert_eq!(t.time, [0.0, 1.0, 2.0]);
        assert_eq!(t.columns.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>(), ["y", "z"]);
        let y = t.column("y").unwrap();
        assert!(y[0] == 1.5 && y[1].is_nan() && y[2].is_nan());
        assert_eq!(t.column("z").unwrap(), [1.0, 2.0, 3.0]);
    }

    #[test]
    fn missing_cells_are_errors_when_refused_but_nan_is_left_to_validation() {
        let dir = tempfile::tempdir().unwrap();
        let p = file(&dir, "in.csv", "time,u\n0,1\n1,\n");
        let e = read_csv(&p, &INPUTS).unwrap_err();
        assert_eq!(e.to_string(), format!("{} line 3: column \"u\": \"\" is not a number", p.display()));
        let p = file(&dir, "nan.csv", "time,u\n0,1\n1,nan\n");
        assert!(read_csv(&p, &INPUTS).unwrap().column("u").unwrap()[1].is_nan());
    }

    #[test]
    fn the_time_column_must_be_there_and_first_if_so_laid_out() {
        let dir = tempfile::tempdir().unwrap();
        let p = file(&dir, "t.csv", "u,time\n0,0\n");
        assert_eq!(fault(read_csv(&p, &INPUTS)), (Some(1), "the first column must be named \"time\"".into()));
        assert_eq!(read_csv(&p, &MEASUREMENTS).unwrap().time, [0.0]);
        let named_t = Layout { time: TimeColumn::Named("t"), ..MEASUREMENTS };
        assert_eq!(
            fault(read_csv(&p, &named_t)),
            (Some(1), "no column named \"t\"; the closest: \"u\", \"time\"".into())
        );
        // `Time` is time when no column is named `time` and no other differs from it in case only.
        let p = file(&dir, "upper.csv", "Time,u\n0,1\n");
        assert_eq!(read_csv(&p, &INPUTS).unwrap().time, [0.0]);
        assert_eq!(read_csv(&p, &MEASUREMENTS).unwrap().columns[0].0, "u");
    }

    #[test]
    fn reads_stop_at_the_cap_and_a_byte_order_mark_is_skipped() {
        let dir = tempfile::tempdir().unwrap();
        let p = file(&dir, "d.csv", "\u{feff}time,y\n0,1\n1,2\n");
        let t = read_capped(&p, &MEASUREMENTS, 100).unwrap();
        assert_eq!((t.time.as_slice(), t.columns[0].0.as_str()), ([0.0, 1.0].as_slice(), "y"));
        let exact = std::fs::metadata(&p).unwrap().len();
        read_capped(&p, &MEASUREMENTS, exact).unwrap();
        let (line, message) = fault(read_capped(&p, &MEASUREMENTS, exact - 1));
        assert_eq!(
            (line, message.as_str()),
            (None, format!("the file exceeds the cap of {} bytes", exact - 1).as_str())
        );
        let (_, message) = fault(read_capped(dir.path(), &MEASUREMENTS, 100));
        assert_eq!(message, "it is a directory, not a regular file");
        let (_, message) = fault(read_csv_capped(Path::new("/dev/zero"), &INPUTS, 100));
        assert_eq!(message, "it is a character device, not a regular file");
        let mat = file(&dir, "d.mat", vec![0u8; 4096]);
        let (_, message) = fault(read_capped(&mat, &MEASUREMENTS, 1000));
        assert_eq!(message, "the file exceeds the cap of 1000 bytes");
    }

    #[test]
    fn malformed_csv_names_the_line() {
        let dir = tempfile::tempdir().unwrap();
        let cases = [
            ("time,u,v\n0,0,0\n1,1\n", Some(3), "2 cells for 3 columns, column \"v\" is missing"),
            ("time,u\n0,0,0\n", Some(2), "3 cells for 2 columns"),
            ("time,u\n0,0\n1,x\n", Some(3), "column \"u\": \"x\" is not a number"),
            ("time,u,u\n0,0,0\n", Some(1), "column \"u\" appears twice"),
            ("time,u\n", None, "no data rows"),
        ];
        for (i, (text, line, message)) in cases.into_iter().enumerate() {
            let p = file(&dir, &format!("{i}.csv"), text);
            for layout in [INPUTS, MEASUREMENTS] {
                assert_eq!(fault(read_csv(&p, &layout)), (line, message.to_owned()), "{text:?}");
            }
        }
        let e = read_csv(&dir.path().join("absent.csv"), &INPUTS).unwrap_err();
        assert_eq!(e.line, None);
    }

    #[test]
    fn the_delimiter_is_the_commonest_of_comma_semicolon_and_tab_in_the_header() {
        assert_eq!(delimiter(b"time,y\n"), b',');
        assert_eq!(delimiter(b"time;y;z\n"), b';');
        assert_eq!(delimiter(b"time\ty\n"), b'\t');
        assert_eq!(delimiter(b"\"a,b\";y\n"), b';');
        assert_eq!(delimiter(b"time\n"), b',');
        let dir = tempfile::tempdir().unwrap();
        let p = file(&dir, "d.csv", "time;y\n0;1,5\n1;2.5\n");
        assert_eq!(read_csv(&p, &MEASUREMENTS).unwrap().column("y").unwrap(), [1.5, 2.5]);
        // Decimal commas only where commas do not separate.
        let p = file(&dir, "c.csv", "time,y\n0,\"1,5\"\n");
        assert_eq!(fault(read_csv(&p, &MEASUREMENTS)), (Some(2), "column \"y\": \"1,5\" is not a number".into()));
    }

    #[test]
    fn closest_names_by_edit_distance() {
        assert_eq!(super::super::closest("phii", ["theta", "phi", "Phi_d", "time"], 2), ["phi", "Phi_d"]);
        assert_eq!(super::super::closest("x", ["a", "b", "c", "d", "e", "f"], 5).len(), 5);
        assert!(super::super::closest("x", [], 5).is_empty());
    }

    /// One little-endian MATLAB v5 data element, padded to 8 bytes.
    fn element(data_type: u32, bytes: &[u8]) -> Vec<u8> {
        let mut out = [data_type.to_le_bytes(), (bytes.len() as u32).to_le_bytes()].concat();
        out.extend(bytes);
        out.resize(out.len().next_multiple_of(8), 0);
        out
    }

    /// A column vector of class `class` (6 double, 12 int32) whose parts are (type, bytes).
    fn matrix(name: &str, class: u32, n: i32, parts: &[(u32, Vec<u8>)]) -> Vec<u8> {
        let mut body = element(6, &[class.to_le_bytes(), [0; 4]].concat());
        body.extend(element(5, &[n.to_le_bytes(), 1i32.to_le_bytes()].concat()));
        body.extend(element(1, name.as_bytes()));
        for (data_type, bytes) in parts {
            body.extend(element(*data_type, bytes));
        }
        element(14, &body)
    }

    fn doubles(v: &[f64]) -> (u32, Vec<u8>) {
        (9, v.iter().flat_map(|x| x.to_le_bytes()).collect())
    }

    fn mat_v5(arrays: &[Vec<u8>]) -> Vec<u8> {
        let mut out = format!("{:<116}", "MATLAB 5.0 MAT-file, written by fmucal's tests").into_bytes();
        out.extend([0; 8]);
        out.extend(0x0100u16.to_le_bytes());
        out.extend(b"IM");
        out.extend(arrays.concat());
        out
    }

    #[test]
    fn mat_files_give_every_real_numeric_array_but_time_as_a_column() {
        let dir = tempfile::tempdir().unwrap();
        let complex = 6 | 0x0800;
        let bytes = mat_v5(&[
            matrix("phi", 6, 3, &[doubles(&[1.0, f64::NAN, 3.0])]),
            matrix("time", 6, 3, &[doubles(&[0.0, 0.5, 1.0])]),
            // An int32 array stored as uint8, as MATLAB stores small integers.
            matrix("n", 12, 3, &[(2, vec![4, 5, 6])]),
            matrix("z", complex, 3, &[doubles(&[1.0; 3]), doubles(&[2.0; 3])]),
        ]);
        let p = file(&dir, "d.MAT", &bytes);
        let t = read(&p, &INPUTS).unwrap();
        assert_eq!(t.time, [0.0, 0.5, 1.0]);
        assert_eq!(t.columns.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>(), ["phi", "n"]);
        let phi = t.column("phi").unwrap();
        assert!(phi[0] == 1.0 && phi[1].is_nan() && phi[2] == 3.0);
        assert_eq!(t.column("n").unwrap(), [4.0, 5.0, 6.0]);

        let named_t = Layout { time: TimeColumn::Named("t"), ..MEASUREMENTS };
        assert_eq!(
            fault(read(&p, &named_t)),
            (None, "no variable named \"t\"; the closest: \"n\", \"z\", \"phi\", \"time\"".into())
        );
        let as_time = Layout { time: TimeColumn::Named("z"), ..MEASUREMENTS };
        assert_eq!(fault(read(&p, &as_time)), (None, "\"z\" is not a real numeric array".into()));
        let p = file(&dir, "text.mat", "time,y\n0,1\n");
        assert_eq!(fault(read(&p, &MEASUREMENTS)).1, "neither a MATLAB v4 nor a v5 file");
    }

    #[test]
    fn a_truncated_mat_file_is_called_truncated() {
        let dir = tempfile::tempdir().unwrap();
        let whole =
            std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/furuta/FurutaData.mat")).unwrap();
        assert_eq!(mat_truncated_at(&whole), None);
        let synthetic =
            mat_v5(&[matrix("time", 6, 3, &[doubles(&[0.0, 0.5, 1.0])]), matrix("y", 6, 3, &[doubles(&[1.0; 3])])]);
        assert_eq!(mat_truncated_at(&synthetic), None);
        for bytes in
            [&whole[..whole.len() / 2], &whole[..whole.len() - 1], &whole[..100], &synthetic[..synthetic.len() - 9]]
        {
            let p = file(&dir, "cut.mat", bytes);
            let message = fault(read(&p, &MEASUREMENTS)).1;
            assert!(
                message.contains("truncated or invalid") || message.starts_with("not a MATLAB v5 file"),
                "{message}"
            );
            assert!(!message.contains("no variable named"), "{message}");
        }
    }
}
