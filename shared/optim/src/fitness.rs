//! A total order on objective results: finite and infinite values by `f64::total_cmp`, with
//! failures (and NaN) after everything. No comparison ever treats NaN as equal.

use serde::{Deserialize, Serialize};

use super::Outcome;

/// An evaluated objective, ordered best (smallest) first; `Failed` ranks last.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Fitness {
    Value(#[serde(with = "super::serde_float")] f64),
    Failed,
}

impl From<Outcome> for Fitness {
    fn from(o: Outcome) -> Self {
        match o {
            Outcome::Value(v) if !v.is_nan() => Fitness::Value(v),
            _ => Fitness::Failed,
        }
    }
}

impl Fitness {
    /// Total order: values by `total_cmp` (−∞ < finite < +∞), then `Failed`.
    pub fn cmp(&self, other: &Fitness) -> std::cmp::Ordering {
        use std::cmp::Ordering::*;
        match (self, other) {
            (Fitness::Value(a), Fitness::Value(b)) => a.total_cmp(b),
            (Fitness::Value(_), Fitness::Failed) => Less,
            (Fitness::Failed, Fitness::Value(_)) => Greater,
            (Fitness::Failed, Fitness::Failed) => Equal,
        }
    }

    /// Strictly better than `other`.
    pub fn lt(&self, other: &Fitness) -> bool {
        self.cmp(other) == std::cmp::Ordering::Less
    }

    /// The value, if finite.
    pub fn finite(&self) -> Option<f64> {
        match self {
            Fitness::Value(v) if v.is_finite() => Some(*v),
            _ => None,
        }
    }
}

/// max − min of the values, or +∞ if any is failed or infinite.
pub fn spread(values: impl IntoIterator<Item = Fitness>) -> f64 {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for f in values {
        let Some(v) = f.finite() else { return f64::INFINITY };
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if hi < lo { 0.0 } else { hi - lo }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failed_and_nan_rank_after_every_value() {
        let failed: Fitness = Outcome::Value(f64::NAN).into();
        assert_eq!(failed, Fitness::Failed);
        for v in [f64::NEG_INFINITY, -1.0, 0.0, 1e300, f64::INFINITY] {
            assert!(Fitness::Value(v).lt(&failed));
            assert!(!failed.lt(&Fitness::Value(v)));
        }
        assert!(!failed.lt(&failed));
    }

    #[test]
    fn spread_is_infinite_with_a_failure() {
        assert_eq!(spread([Fitness::Value(1.0), Fitness::Value(3.0)]), 2.0);
        assert_eq!(spread([Fitness::Value(1.0), Fitness::Failed]), f64::INFINITY);
    }
}
