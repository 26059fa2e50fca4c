//! The journal's binary encoding: how the told points of a running job are kept in the store
//! (table `journal`), so that a restarted coordinator tells the points of the open batch again
//! instead of evaluating them again ([`crate::store`]).
//!
//! One stored value is a block of the points one job had told when the scheduler last flushed
//! (every 50 ms tick and at every batch end), keyed by the job and the block's lowest point id;
//! each saved job state removes the blocks before it, so a job's journal holds at most its open
//! batch. A block is a format byte ([`FORMAT`]), then one record per point:
//!
//! | field | encoding |
//! |---|---|
//! | point id | LEB128 varint |
//! | flags | one byte: 1 value, 2 residuals, 4 error (which of the three are present) |
//! | x | LEB128 count, then each value as f64 little-endian |
//! | value | f64 little-endian, if flagged (+inf stays apart from a failure) |
//! | residuals | LEB128 count, then f64 little-endian each, if flagged |
//! | error | LEB128 length, then UTF-8, if flagged |
//!
//! Every f64 is kept bit for bit, so a resumed job is told exactly what it was told before.
//! The point's x is kept so that a resumed job tells a logged value only to the same point
//! (bit for bit); the simulation's wall time is not kept (neither the optimizer nor the result
//! uses it). With up to 4 parameters a record is at most 51 bytes; a least-squares record
//! adds 8 bytes per residual.
//!
//! Stores written before this encoding kept one JSON [`Evaluation`] per point (table
//! `evaluations`, no x): [`crate::store::Store::evaluations`] still reads them.

use fmucal_shared::job::Evaluation;

/// The first byte of every block: the version of this encoding.
pub const FORMAT: u8 = 1;

const VALUE: u8 = 1;
const RESIDUALS: u8 = 2;
const ERROR: u8 = 4;

/// One told point as the journal keeps it.
#[derive(Debug, Clone, PartialEq)]
pub struct Logged {
    /// The work item's id in its job.
    pub point: u64,
    /// The point as it was handed out; `None` for an entry of the former JSON log, which did
    /// not keep it.
    pub x: Option<Vec<f64>>,
    pub evaluation: Evaluation,
}

/// Why a stored block does not read back.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum JournalError {
    #[error("journal block: format {0} is not one this version reads")]
    Format(u8),
    #[error("journal block: cut short in its {0}")]
    Truncated(&'static str),
    #[error("journal block: its error message is not UTF-8")]
    NotUtf8,
}

/// Encodes one job's told points as one block (`points`: id, x, evaluation).
pub fn encode<'a>(points: impl IntoIterator<Item = (u64, &'a [f64], &'a Evaluation)>) -> Vec<u8> {
    let mut out = vec![FORMAT];
    for (point, x, e) in points {
        varint(&mut out, point);
        let flags = if e.value.is_some() { VALUE } else { 0 }
            | if e.residuals.is_some() { RESIDUALS } else { 0 }
            | if e.error.is_some() { ERROR } else { 0 };
        out.push(flags);
        floats(&mut out, x);
        if let Some(v) = e.value {
            out.extend_from_slice(&v.to_le_bytes());
        }
        if let Some(r) = &e.residuals {
            floats(&mut out, r);
        }
        if let Some(msg) = &e.error {
            varint(&mut out, msg.len() as u64);
            out.extend_from_slice(msg.as_bytes());
        }
    }
    out
}

/// The points of a block, in the order they were encoded.
///
/// # Errors
/// [`JournalError`] for a block of another format, or cut short.
pub fn decode(block: &[u8]) -> Result<Vec<Logged>, JournalError> {
    let mut r = Reader { bytes: block };
    let format = r.byte("format")?;
    if format != FORMAT {
        return Err(JournalError::Format(format));
    }
    let mut out = vec![];
    while !r.bytes.is_empty() {
        let point = r.varint("point id")?;
        let flags = r.byte("flags")?;
        let x = r.floats("x")?;
        let value = if flags & VALUE != 0 { Some(r.float("value")?) } else { None };
        let residuals = if flags & RESIDUALS != 0 { Some(r.floats("residuals")?) } else { None };
        let error = if flags & ERROR != 0 {
            let n = r.len("error")?;
            let bytes = r.take(n, "error")?;
            Some(String::from_utf8(bytes.to_vec()).map_err(|_| JournalError::NotUtf8)?)
        } else {
            None
        };
        let evaluation = Evaluation { value, residuals, error, wall: std::time::Duration::ZERO };
        out.push(Logged { point, x: Some(x), evaluation });
    }
    Ok(out)
}

fn varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

fn floats(out: &mut Vec<u8>, values: &[f64]) {
    varint(out, values.len() as u64);
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

struct Reader<'a> {
    bytes: &'a [u8],
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize, what: &'static str) -> Result<&'a [u8], JournalError> {
        if self.bytes.len() < n {
            return Err(JournalError::Truncated(what));
        }
        let (head, rest) = self.bytes.split_at(n);
        self.bytes = rest;
        Ok(head)
    }

    fn byte(&mut self, what: &'static str) -> Result<u8, JournalError> {
        Ok(self.take(1, what)?[0])
    }

    fn varint(&mut self, what: &'static str) -> Result<u64, JournalError> {
        let mut v = 0u64;
        for shift in (0..64).step_by(7) {
            let b = self.byte(what)?;
            v |= u64::from(b & 0x7f) << shift;
            if b & 0x80 == 0 {
                return Ok(v);
            }
        }
        Err(JournalError::Truncated(what))
    }

    /// A count of items that must fit in what is left (so a damaged count cannot allocate).
    fn len(&mut self, what: &'static str) -> Result<usize, JournalError> {
        let n = self.varint(what)?;
        usize::try_from(n).ok().filter(|&n| n <= self.bytes.len()).ok_or(JournalError::Truncated(what))
    }

    fn float(&mut self, what: &'static str) -> Result<f64, JournalError> {
        let b = self.take(8, what)?;
        Ok(f64::from_le_bytes(b.try_into().expect("8 bytes")))
    }

    fn floats(&mut self, what: &'static str) -> Result<Vec<f64>, JournalError> {
        let n = self.varint(what)?;
        let n = usize::try_from(n).ok().filter(|&n| n <= self.bytes.len() / 8).ok_or(JournalError::Truncated(what))?;
        (0..n).map(|_| self.float(what)).collect()
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;

    fn ok(value: f64, residuals: Option<Vec<f64>>) -> Evaluation {
        Evaluation { value: Some(value), residuals, error: None, wall: Duration::from_millis(3) }
    }

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    /// Values, points and residuals come back bit for bit (signed zero, subnormals, +inf and a
    /// NaN payload included), a failure keeps its message and stays apart from +inf, an OK
    /// evaluation without residuals stays apart from one with none; only the wall time is gone.
    #[test]
    fn every_kind_of_evaluation_round_trips_bit_for_bit() {
        let odd = [-0.0, f64::MIN_POSITIVE / 3.0, f64::INFINITY, f64::from_bits(0x7ff8_0000_0000_0abc), 1e308];
        let cases: Vec<(u64, Vec<f64>, Evaluation)> = vec![
            (0, vec![1.0, 2.5, -3.25, 1e-300], ok(0.125, None)),
            (7, odd.to_vec(), ok(f64::INFINITY, Some(vec![]))),
            (300, vec![0.1], ok(-0.0, Some(odd.to_vec()))),
            (u64::MAX, vec![], Evaluation::failed("the solver failed at t = 1.5: ß ∞")),
            (1 << 40, vec![2.0; 3], Evaluation { value: None, residuals: None, error: None, wall: Duration::ZERO }),
        ];
        let block = encode(cases.iter().map(|(p, x, e)| (*p, x.as_slice(), e)));
        let back = decode(&block).unwrap();
        assert_eq!(back.len(), cases.len());
        for ((p, x, e), got) in cases.iter().zip(&back) {
            assert_eq!(got.point, *p);
            assert_eq!(bits(got.x.as_ref().unwrap()), bits(x));
            assert_eq!(got.evaluation.value.map(f64::to_bits), e.value.map(f64::to_bits));
            assert_eq!(got.evaluation.residuals.as_deref().map(bits), e.residuals.as_deref().map(bits));
            assert_eq!(got.evaluation.error, e.error);
            assert_eq!(got.evaluation.wall, Duration::ZERO);
        }
    }

    /// A record of a 4-parameter point is small: what makes the journal at most 100 bytes per
    /// evaluation for such jobs (the rest is the store's key and page overhead).
    #[test]
    fn a_four_parameter_record_takes_at_most_51_bytes() {
        let e = ok(3.5, Some(vec![]));
        let one = encode([(u64::from(u32::MAX), [1.0, 2.0, 3.0, 4.0].as_slice(), &e)]);
        assert_eq!(one.len() - 1, 5 + 1 + 1 + 32 + 8 + 1);
        let many = encode((0..100u64).map(|p| (p, [1.0, 2.0, 3.0, 4.0].as_slice(), &e)));
        assert!(many.len() <= 1 + 100 * 46, "{}", many.len());
    }

    /// A block cut anywhere, or of another format, is an error, never a panic or a wrong record.
    #[test]
    fn a_damaged_block_is_refused() {
        let e = Evaluation::failed("boom");
        let r = ok(1.0, Some(vec![1.0, 2.0]));
        let block = encode([(1, [0.5, 0.25].as_slice(), &r), (2, [0.5].as_slice(), &e)]);
        let boundary = encode([(1, [0.5, 0.25].as_slice(), &r)]).len();
        for cut in 1..block.len() {
            match decode(&block[..cut]) {
                Ok(v) if cut == 1 => assert!(v.is_empty()),
                Ok(v) if cut == boundary => assert_eq!(v.len(), 1),
                got => assert!(got.is_err(), "cut at {cut}: {got:?}"),
            }
        }
        let mut other = block.clone();
        other[0] = 9;
        assert_eq!(decode(&other), Err(JournalError::Format(9)));
        assert_eq!(decode(&[]), Err(JournalError::Truncated("format")));
        // A huge count in a short block does not allocate it.
        let mut huge = vec![FORMAT, 1, VALUE];
        huge.extend([0xff, 0xff, 0xff, 0xff, 0x0f]);
        assert_eq!(decode(&huge), Err(JournalError::Truncated("x")));
    }
}
