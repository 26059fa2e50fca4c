//! MATLAB v4 `.mat` files, the format of Dymola's `dsres.mat` and OpenModelica's `_res.mat`.
//!
//! A v4 file is a sequence of matrices, each a 20-byte header of five 32-bit integers (the
//! type code `MOPT`, `mrows`, `ncols`, `imagf`, `namlen`), the name (`namlen` bytes with its
//! NUL), then `mrows × ncols` values in column order (and as many imaginary ones if `imagf`).
//! `M` is the byte order (0 little-endian, 1 big-endian; the VAX and Cray formats 2 to 4 are
//! refused), `O` is 0, `P` the element type (0 double, 1 single, 2 int32, 3 int16, 4 uint16,
//! 5 uint8) and `T` 0 for numbers, 1 for text (a char matrix) or 2 for sparse.
//!
//! A Modelica result file holds `Aclass` (text: `Atrajectory`, a version, an empty row, then
//! `binTrans` when the next matrices are stored transposed, `binNormal` when not), `name` and
//! `description` (char matrices, one string per variable), `dataInfo` (integers, per variable:
//! the data matrix, 1 for `data_1` or 2 for `data_2`, 0 for the time axis which is `data_2`'s
//! first column, then the 1-based column in that matrix, negative for a negated alias), the
//! parameters in `data_1` and the trajectories in `data_2` (float64 or float32), both with
//! time first. A variable of `data_1` is constant: its first value, repeated at every time.
//!
//! A v4 file without `Aclass` is read as a v5 one is: every real numeric matrix a column named
//! after it. The file is hostile: every size is checked against the bytes there are before
//! anything is allocated, and every fault is one line.

use crate::quote::quote_user_text;

/// One matrix of the file, its values left in the bytes.
struct Matrix<'a> {
    name: String,
    rows: usize,
    cols: usize,
    precision: u32,
    text: bool,
    complex: bool,
    big_endian: bool,
    /// The real part's bytes, `rows × cols` elements in column order.
    real: &'a [u8],
}

use super::MAX_VALUES;

/// Whether `bytes` starts as a v4 file does: a known type code in either byte order.
pub(super) fn looks_like_v4(bytes: &[u8]) -> bool {
    bytes.len() >= 20 && type_code(&bytes[..4]).is_some()
}

/// The type code's digits (M, P, T) and its byte order (true: big-endian), if it is one.
fn type_code(word: &[u8]) -> Option<(u32, u32, u32, bool)> {
    let w = [word[0], word[1], word[2], word[3]];
    for (value, big) in [(u32::from_le_bytes(w), false), (u32::from_be_bytes(w), true)] {
        let (m, o, p, t) = (value / 1000, value / 100 % 10, value / 10 % 10, value % 10);
        if value < 5000 && o == 0 && p <= 5 && t <= 2 && (m == u32::from(big) || m >= 2) {
            return Some((m, p, t, big));
        }
    }
    None
}

fn element_size(precision: u32) -> usize {
    match precision {
        0 => 8,
        1 | 2 => 4,
        3 | 4 => 2,
        _ => 1,
    }
}

impl Matrix<'_> {
    fn len(&self) -> usize {
        self.rows * self.cols
    }

    /// Element `i` in storage order (`i < self.len()`).
    fn at(&self, i: usize) -> f64 {
        let size = element_size(self.precision);
        let b = &self.real[i * size..(i + 1) * size];
        macro_rules! num {
            ($t:ty) => {{
                let a = b.try_into().expect("sized");
                (if self.big_endian { <$t>::from_be_bytes(a) } else { <$t>::from_le_bytes(a) }) as f64
            }};
        }
        match self.precision {
            0 => num!(f64),
            1 => num!(f32),
            2 => num!(i32),
            3 => num!(i16),
            4 => num!(u16),
            _ => f64::from(b[0]),
        }
    }

    /// Element (row `r`, column `c`) of the matrix as a result file means it: transposed
    /// (`binTrans`) or not.
    fn get(&self, r: usize, c: usize, transposed: bool) -> f64 {
        if transposed { self.at(r * self.rows + c) } else { self.at(c * self.rows + r) }
    }

    /// Rows and columns as a result file means them.
    fn shape(&self, transposed: bool) -> (usize, usize) {
        if transposed { (self.cols, self.rows) } else { (self.rows, self.cols) }
    }

    /// The rows of a char matrix as strings (trailing NULs and spaces dropped).
    fn strings(&self, transposed: bool) -> Vec<String> {
        let (n, width) = self.shape(transposed);
        (0..n)
            .map(|r| {
                let chars: Vec<u8> = (0..width)
                    .map(|c| {
                        let v = self.get(r, c, transposed);
                        if (0.0..=255.0).contains(&v) { v as u8 } else { b'?' }
                    })
                    .collect();
                String::from_utf8_lossy(&chars).trim_end_matches(['\0', ' ']).to_owned()
            })
            .collect()
    }
}

/// The file's matrices, each checked to fit in the bytes there are.
fn matrices(bytes: &[u8]) -> Result<Vec<Matrix<'_>>, String> {
    let mut out = vec![];
    let mut at = 0usize;
    while at < bytes.len() {
        let Some(header) = bytes.get(at..at + 20) else {
            return Err(format!(
                "truncated MATLAB v4 file: {} bytes at byte {at} are not a whole header",
                bytes.len() - at
            ));
        };
        let (m, precision, kind, big_endian) = type_code(&header[..4])
            .ok_or_else(|| format!("invalid MATLAB v4 file: no matrix type code at byte {at}"))?;
        if m >= 2 {
            return Err(format!("MATLAB v4 file in the VAX or Cray number format (type code {m}xxx) is not supported"));
        }
        let word = |i: usize| {
            let w = [header[4 * i], header[4 * i + 1], header[4 * i + 2], header[4 * i + 3]];
            if big_endian { i32::from_be_bytes(w) } else { i32::from_le_bytes(w) }
        };
        let (rows, cols, imagf, namlen) = (word(1), word(2), word(3), word(4));
        if rows < 0 || cols < 0 || !(0..=1).contains(&imagf) || namlen < 1 {
            return Err(format!(
                "invalid MATLAB v4 file: the matrix header at byte {at} says {rows} rows, {cols} columns, \
                 imaginary flag {imagf}, name length {namlen}"
            ));
        }
        let name_at = at + 20;
        let name_end = name_at.checked_add(namlen as usize).filter(|&e| e <= bytes.len()).ok_or_else(|| {
            format!("truncated MATLAB v4 file: the name of the matrix at byte {at} runs past the end")
        })?;
        let raw = &bytes[name_at..name_end];
        let name = String::from_utf8_lossy(raw.split(|&b| b == 0).next().unwrap_or_default()).into_owned();
        let (rows, cols) = (rows as usize, cols as usize);
        if rows.min(cols) == 0 && rows.max(cols) > MAX_EMPTY_SIDE {
            return Err(too_large(&name, rows, cols));
        }
        let part = rows
            .checked_mul(cols)
            .and_then(|n| n.checked_mul(element_size(precision)))
            .filter(|&n| n <= bytes.len())
            .ok_or_else(|| too_large(&name, rows, cols))?;
        let parts = if imagf == 1 { 2 } else { 1 };
        let end = name_end.checked_add(part * parts).filter(|&e| e <= bytes.len()).ok_or_else(|| {
            format!(
                "truncated MATLAB v4 file: matrix {} ({rows}×{cols}) needs {} bytes at byte {name_end}, {} are left",
                quote_user_text(&name),
                part * parts,
                bytes.len() - name_end
            )
        })?;
        out.push(Matrix {
            name,
            rows,
            cols,
            precision,
            text: kind == 1,
            complex: imagf == 1,
            big_endian,
            real: &bytes[name_end..name_end + part],
        });
        at = end;
    }
    Ok(out)
}

/// The longest side of an empty matrix: its other side is 0, so no bytes bound it.
const MAX_EMPTY_SIDE: usize = 1 << 20;

fn too_large(name: &str, rows: usize, cols: usize) -> String {
    format!(
        "truncated MATLAB v4 file: matrix {} says {rows}×{cols} values, more than the file holds",
        quote_user_text(name)
    )
}

type Wanted<'a> = std::collections::HashSet<&'a str>;

/// A v4 file read: the time values, the columns chosen, and the name of every variable in it
/// but time.
pub(super) struct Read {
    pub time: Vec<f64>,
    pub columns: Vec<(String, Vec<f64>)>,
    pub names: Vec<String>,
}

/// Reads a v4 file: the variable `time` (found as [`super::read::find_time`] finds a column)
/// as time, and every other variable, or only those in `wanted` when given, as columns.
///
/// # Errors
/// One line saying what is wrong: a truncated or invalid matrix, a result file without the
/// matrices it needs or whose `dataInfo` points outside them, no time variable, or a
/// selection over the cap of values.
pub(super) fn read(bytes: &[u8], time: &str, wanted: Option<&[&str]>) -> Result<Read, String> {
    let wanted: Option<std::collections::HashSet<&str>> = wanted.map(|w| w.iter().copied().collect());
    let wanted = wanted.as_ref();
    let all = matrices(bytes)?;
    let find = |name: &str| all.iter().find(|m| m.name == name);
    match find("Aclass") {
        Some(aclass) => result_file(aclass, &find, time, wanted),
        None => plain(&all, time, wanted),
    }
}

/// A v4 file of plain matrices: each real numeric one a column named after it.
fn plain(all: &[Matrix], time: &str, wanted: Option<&Wanted>) -> Result<Read, String> {
    let numeric: Vec<&Matrix> = all.iter().filter(|m| !m.text && !m.complex).collect();
    let names: Vec<String> = numeric.iter().map(|m| m.name.clone()).collect();
    let t = super::read::find_time(&names, time).map_err(|e| e.replace("column", "variable"))?;
    let values = |m: &Matrix| (0..m.len()).map(|i| m.at(i)).collect::<Vec<f64>>();
    let chosen: Vec<&Matrix> = numeric
        .iter()
        .enumerate()
        .filter(|&(i, m)| i != t && wanted.is_none_or(|w| w.contains(m.name.as_str())))
        .map(|(_, m)| *m)
        .collect();
    let total = chosen.iter().map(|m| m.len()).fold(numeric[t].len(), usize::saturating_add);
    if total > MAX_VALUES {
        return Err(format!("{total} values exceed the cap of {MAX_VALUES}"));
    }
    let time_values = values(numeric[t]);
    let columns = chosen.into_iter().map(|m| (m.name.clone(), values(m))).collect();
    let mut names = names;
    names.remove(t);
    Ok(Read { time: time_values, columns, names })
}

/// A Modelica result file (`Aclass` present).
fn result_file<'a>(
    aclass: &Matrix,
    find: &dyn Fn(&str) -> Option<&'a Matrix<'a>>,
    time: &str,
    wanted: Option<&Wanted>,
) -> Result<Read, String> {
    if !aclass.text {
        return Err("invalid result file: Aclass is not a char matrix".into());
    }
    let class = aclass.strings(false);
    if class.first().map(String::as_str) != Some("Atrajectory") {
        return Err(format!(
            "not a Modelica result file: Aclass starts with {}, not \"Atrajectory\"",
            quote_user_text(class.first().map_or("", String::as_str))
        ));
    }
    let transposed = match class.get(3).map(String::as_str) {
        Some("binTrans") => true,
        Some("binNormal") | None => false,
        Some(other) => return Err(format!("invalid result file: Aclass says {}", quote_user_text(other))),
    };
    let need = |name: &str| find(name).ok_or_else(|| format!("invalid result file: no {name} matrix"));
    let name_matrix = need("name")?;
    if !name_matrix.text {
        return Err("invalid result file: name is not a char matrix".into());
    }
    let names = name_matrix.strings(transposed);
    let info = need("dataInfo")?;
    let (info_rows, info_cols) = info.shape(transposed);
    if info_rows != names.len() || info_cols < 2 {
        return Err(format!(
            "invalid result file: dataInfo is {info_rows}×{info_cols} for {} names (it needs a row of at least 2 per name)",
            names.len()
        ));
    }
    let data_2 = need("data_2")?;
    let data_1 = find("data_1");
    let (times, _) = data_2.shape(transposed);
    if times == 0 {
        return Err("no data rows: data_2 holds no time points".into());
    }
    // Where variable `j`'s values stand: (matrix, 0-based column, negated).
    let locate = |j: usize| -> Result<(&Matrix, usize, bool), String> {
        let (block, index) = (info.get(j, 0, transposed), info.get(j, 1, transposed));
        let bad = |what: &str| format!("invalid result file: dataInfo of {} {what}", quote_user_text(&names[j]));
        let matrix = match block {
            0.0 | 2.0 => data_2,
            1.0 => data_1.ok_or_else(|| bad("points into data_1, which the file lacks"))?,
            _ => return Err(bad(&format!("names data matrix {block}"))),
        };
        let width = matrix.shape(transposed).1;
        let column = index.abs();
        if index.fract() != 0.0 || column < 1.0 || column > width as f64 {
            return Err(bad(&format!("points to column {index} of a matrix of {width}")));
        }
        Ok((matrix, column as usize - 1, index < 0.0))
    };
    let values = |j: usize| -> Result<Vec<f64>, String> {
        let (matrix, column, negated) = locate(j)?;
        let sign = if negated { -1.0 } else { 1.0 };
        let (rows, _) = matrix.shape(transposed);
        if std::ptr::eq(matrix, data_2) {
            Ok((0..times).map(|k| sign * matrix.get(k, column, transposed)).collect())
        } else if rows == 0 {
            Err(format!("invalid result file: data_1 holds no rows for {}", quote_user_text(&names[j])))
        } else {
            Ok(vec![sign * matrix.get(0, column, transposed); times])
        }
    };
    let t = super::read::find_time(&names, time).map_err(|e| e.replace("column", "variable"))?;
    // A name given twice (no writer does so) is read once, at its first place.
    let mut seen = std::collections::HashSet::new();
    let chosen: Vec<usize> = (0..names.len())
        .filter(|&j| seen.insert(names[j].as_str()))
        .filter(|&j| j != t && wanted.is_none_or(|w| w.contains(names[j].as_str())))
        .collect();
    let total = (chosen.len() + 1).saturating_mul(times);
    if total > MAX_VALUES {
        return Err(format!(
            "{} variables × {times} time points is {total} values, which exceeds the cap of {MAX_VALUES}",
            chosen.len() + 1
        ));
    }
    let time_values = values(t)?;
    let columns = chosen.into_iter().map(|j| Ok((names[j].clone(), values(j)?))).collect::<Result<_, String>>()?;
    let mut names = names;
    names.remove(t);
    Ok(Read { time: time_values, columns, names })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A big-endian double matrix, as a v4 writer on such a machine writes it (type code 1000).
    fn big_endian(name: &str, values: &[f64]) -> Vec<u8> {
        let header = [1000, values.len() as i32, 1, 0, name.len() as i32 + 1];
        let mut out: Vec<u8> = header.iter().flat_map(|v| v.to_be_bytes()).collect();
        out.extend(name.as_bytes());
        out.push(0);
        out.extend(values.iter().flat_map(|v| v.to_be_bytes()));
        out
    }

    #[test]
    fn plain_big_endian_matrices_are_columns_by_name() {
        let bytes =
            [big_endian("Time", &[0.0, 0.5]), big_endian("y", &[1.0, -2.0]), big_endian("z", &[3.0, 4.0])].concat();
        assert!(looks_like_v4(&bytes));
        let r = read(&bytes, "time", None).unwrap();
        assert_eq!(r.time, [0.0, 0.5]);
        assert_eq!(r.columns, [("y".to_owned(), vec![1.0, -2.0]), ("z".to_owned(), vec![3.0, 4.0])]);
        assert_eq!(r.names, ["y", "z"]);
        let r = read(&bytes, "time", Some(&["z"])).unwrap();
        assert_eq!((r.columns.len(), r.names.len()), (1, 2));
        assert_eq!(
            read(&bytes, "t", None).err().unwrap(),
            "no variable named \"t\"; the closest: \"y\", \"z\", \"Time\""
        );
    }
}
