//! Input time series: a [`TimeSeries`] checked as simulation inputs, interpolated linearly for
//! continuous Real inputs and held (right-continuous) for discrete ones, as FMPy does. Repeated
//! time stamps mark a jump: at exactly that time the later row applies. Before the first and
//! after the last sample, the end values are held.

use super::spec::SimError;
use super::time_eps;
use crate::series::{TimeFault, TimeSeries};

/// Which limit to take at a time where a signal jumps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    Left,
    Right,
}

/// Samples of named input signals: the name the integration tests build inputs by.
pub type InputTable = TimeSeries;

impl TimeSeries {
    /// Checks the table as inputs: at least one row, finite values, non-decreasing time, equal
    /// lengths.
    ///
    /// # Errors
    /// [`SimError::Invalid`] naming the column and row at fault.
    pub fn validate_inputs(&self) -> Result<(), SimError> {
        self.check_time().map_err(|fault| {
            SimError::Invalid(match fault {
                TimeFault::NoRows => "input table has no rows".into(),
                TimeFault::NotFinite { row } => format!("input time in row {row} is not a finite number"),
                TimeFault::Decreasing { .. } => format!("input time is {fault}"),
            })
        })?;
        for (name, values) in &self.columns {
            if values.len() != self.time.len() {
                return Err(SimError::Invalid(format!(
                    "input column {name:?} has {} values for {} time stamps",
                    values.len(),
                    self.time.len()
                )));
            }
            if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                return Err(SimError::Invalid(format!("input column {name:?} row {} is not a finite number", i + 1)));
            }
        }
        Ok(())
    }

    /// Value of column `col` at time `t`: linear between samples, or held if `hold`. At a jump
    /// (repeated time stamp) this is the value after it; see [`TimeSeries::value_before`].
    pub fn value(&self, col: usize, t: f64, hold: bool) -> f64 {
        self.value_on(Side::Right, col, t, hold)
    }

    /// The left limit at `t`: at a jump, the value before it (what an integrator must see at
    /// the end of an interval that stops at the jump).
    pub fn value_before(&self, col: usize, t: f64, hold: bool) -> f64 {
        self.value_on(Side::Left, col, t, hold)
    }

    /// Value from the given side of `t`.
    pub fn value_on(&self, side: Side, col: usize, t: f64, hold: bool) -> f64 {
        let v = &self.columns[col].1;
        // The last sample at or before t (Right), or strictly before t (Left), where times
        // within a round-off of each other count as equal.
        let eps = time_eps(t);
        let n = match side {
            Side::Right => self.time.partition_point(|&x| x <= t + eps),
            Side::Left => self.time.partition_point(|&x| x < t - eps),
        };
        let Some(i) = n.checked_sub(1) else {
            return v[0];
        };
        if hold || i + 1 >= self.time.len() {
            return v[i];
        }
        let (t0, t1) = (self.time[i], self.time[i + 1]);
        if t1 <= t0 {
            return v[i + 1];
        }
        let w = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
        v[i] + w * (v[i + 1] - v[i])
    }

    /// The first sample time strictly after `t` (beyond round-off); the Model Exchange driver
    /// never steps past one in a model with event indicators.
    pub fn next_sample(&self, t: f64) -> Option<f64> {
        let eps = time_eps(t);
        self.time.get(self.time.partition_point(|&x| x <= t + eps)).copied()
    }

    /// Sample times strictly after `t` where a held value may change or a jump occurs; the
    /// Model Exchange driver stops the integrator there.
    pub fn next_breakpoint(&self, t: f64, discrete_columns: &[usize]) -> Option<f64> {
        let eps = time_eps(t);
        let start = self.time.partition_point(|&x| x <= t + eps);
        (start..self.time.len()).find_map(|i| {
            let ti = self.time[i];
            let jump = i + 1 < self.time.len() && self.time[i + 1] == ti;
            let held_change =
                i > 0 && discrete_columns.iter().any(|&c| self.columns[c].1[i] != self.columns[c].1[i - 1]);
            (jump || held_change).then_some(ti)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table() -> TimeSeries {
        TimeSeries { time: vec![0.0, 1.0, 1.0, 3.0], columns: vec![("u".into(), vec![0.0, 2.0, 5.0, 9.0])] }
    }

    /// Asserts `read(table(), 0, t, hold) == want` for each (t, hold, want).
    fn assert_reads(read: fn(&TimeSeries, usize, f64, bool) -> f64, cases: &[(f64, bool, f64)]) {
        let table = table();
        for &(t, hold, want) in cases {
            assert_eq!(read(&table, 0, t, hold), want, "at t = {t}, hold {hold}");
        }
    }

    #[test]
    fn linear_interpolation_takes_the_right_value_at_a_jump() {
        let cases = [(0.5, false, 1.0), (1.0, false, 5.0), (2.0, false, 7.0), (-1.0, false, 0.0), (10.0, false, 9.0)];
        assert_reads(TimeSeries::value, &cases);
    }

    #[test]
    fn left_limit_at_a_jump_is_the_value_before_it() {
        let cases = [(1.0, false, 2.0), (0.5, false, 1.0), (1.0, true, 0.0), (0.0, false, 0.0)];
        assert_reads(TimeSeries::value_before, &cases);
    }

    #[test]
    fn times_within_round_off_of_a_jump_are_the_jump() {
        let t = table();
        let noisy = 1.0 + 2.0 * f64::EPSILON;
        assert!((t.value(0, noisy, false) - 5.0).abs() < 1e-12);
        assert_eq!(t.value(0, 1.0 - 2.0 * f64::EPSILON, false), 5.0);
        assert_eq!(t.value_before(0, noisy, false), 2.0);
        assert_eq!(t.next_breakpoint(1.0 - f64::EPSILON, &[]), None);
    }

    #[test]
    fn hold_keeps_the_last_sample() {
        assert_reads(TimeSeries::value, &[(0.99, true, 0.0), (2.5, true, 5.0)]);
    }

    #[test]
    fn decreasing_time_and_nan_are_rejected() {
        let mut t = table();
        t.time[3] = 0.5;
        assert!(t.validate_inputs().unwrap_err().to_string().contains("not monotonic"));
        let mut t = table();
        t.columns[0].1[1] = f64::NAN;
        assert!(t.validate_inputs().unwrap_err().to_string().contains("row 2"));
    }

    #[test]
    fn time_faults_read_as_input_faults() {
        let message = |time: Vec<f64>| TimeSeries { time, columns: vec![] }.validate_inputs().unwrap_err().to_string();
        assert!(message(vec![]).ends_with("input table has no rows"));
        assert!(message(vec![0.0, f64::NAN]).ends_with("input time in row 2 is not a finite number"));
        assert!(message(vec![0.0, 2.0, 1.0]).ends_with("input time is not monotonic: row 3 has t=1 after t=2"));
    }

    #[test]
    fn next_sample_is_strictly_later_beyond_round_off() {
        let t = table();
        assert_eq!(t.next_sample(-1.0), Some(0.0));
        assert_eq!(t.next_sample(0.0), Some(1.0));
        assert_eq!(t.next_sample(1.0 - f64::EPSILON), Some(3.0));
        assert_eq!(t.next_sample(3.0), None);
    }

    #[test]
    fn breakpoints_are_jumps_and_held_changes() {
        let t = table();
        assert_eq!(t.next_breakpoint(0.0, &[]), Some(1.0));
        assert_eq!(t.next_breakpoint(1.0, &[]), None);
        assert_eq!(t.next_breakpoint(1.0, &[0]), Some(3.0));
    }
}
