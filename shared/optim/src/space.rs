//! The search space: box bounds and the scaling between user units and the optimizers'
//! internal variables. Where both bounds are finite, z = (x − lower) / (upper − lower), so the
//! box is [0, 1]ⁿ. Elsewhere z = x / nominal, with nominal = |x0| (or 0.005 where x0 is zero,
//! so that a 5 % step matches SciPy's 0.00025), unless given. This replaces the paper's manual
//! multiplication of the parameters by 1e3.

use serde::{Deserialize, Serialize};

use super::OptimError;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Space {
    #[serde(with = "super::serde_float::vec")]
    lower: Vec<f64>,
    #[serde(with = "super::serde_float::vec")]
    upper: Vec<f64>,
    offset: Vec<f64>,
    scale: Vec<f64>,
}

impl Space {
    /// Builds the space. `x0` (if given) must lie within the bounds; `nominal` overrides the
    /// scale of dimensions that are not bounded on both sides.
    ///
    /// # Errors
    /// [`OptimError::Setting`] naming `lower`, `upper`, `x0` or `nominal` and the index at fault.
    pub fn new(lower: &[f64], upper: &[f64], x0: Option<&[f64]>, nominal: Option<&[f64]>) -> Result<Space, OptimError> {
        let n = lower.len();
        if n == 0 {
            return Err(OptimError::setting("lower", "there must be at least one parameter"));
        }
        if upper.len() != n {
            return Err(OptimError::setting("upper", format!("has {} entries, lower has {n}", upper.len())));
        }
        for (field, v) in [("x0", x0), ("nominal", nominal)] {
            if let Some(v) = v
                && v.len() != n
            {
                return Err(OptimError::setting(field, format!("has {} entries, lower has {n}", v.len())));
            }
        }
        let mut offset = vec![0.0; n];
        let mut scale = vec![1.0; n];
        for i in 0..n {
            let (l, u) = (lower[i], upper[i]);
            if l.is_nan() || u.is_nan() || l == f64::INFINITY || u == f64::NEG_INFINITY {
                return Err(OptimError::setting("lower", format!("bounds of parameter {i} are [{l}, {u}]")));
            }
            if l > u {
                return Err(OptimError::setting("lower", format!("lower[{i}] = {l} is above upper[{i}] = {u}")));
            }
            if let Some(x0) = x0 {
                let x = x0[i];
                if !x.is_finite() || x < l || x > u {
                    return Err(OptimError::setting("x0", format!("x0[{i}] = {x} is outside [{l}, {u}]")));
                }
            }
            if l.is_finite() && u.is_finite() {
                offset[i] = l;
                scale[i] = if u > l { u - l } else { 1.0 };
            } else {
                scale[i] = match nominal.map(|v| v[i]) {
                    Some(s) if s > 0.0 && s.is_finite() => s,
                    Some(s) => {
                        return Err(OptimError::setting("nominal", format!("nominal[{i}] = {s} must be positive")));
                    }
                    None => x0.map(|v| v[i].abs()).filter(|a| *a > 0.0).unwrap_or(0.005),
                };
            }
        }
        Ok(Space { lower: lower.to_vec(), upper: upper.to_vec(), offset, scale })
    }

    pub fn dim(&self) -> usize {
        self.lower.len()
    }

    /// True if every dimension has finite bounds.
    pub fn is_bounded(&self) -> bool {
        self.lower.iter().chain(&self.upper).all(|v| v.is_finite())
    }

    /// Scaled bounds of dimension i.
    pub fn z_bounds(&self, i: usize) -> (f64, f64) {
        if self.lower[i] == self.upper[i] {
            return (0.0, 0.0);
        }
        ((self.lower[i] - self.offset[i]) / self.scale[i], (self.upper[i] - self.offset[i]) / self.scale[i])
    }

    /// User point of a scaled point, clamped into the box (so rounding never leaves it).
    pub fn to_user(&self, z: &[f64]) -> Vec<f64> {
        (0..self.dim()).map(|i| (self.offset[i] + self.scale[i] * z[i]).clamp(self.lower[i], self.upper[i])).collect()
    }

    /// Scaled point of a user point.
    pub fn to_scaled(&self, x: &[f64]) -> Vec<f64> {
        (0..self.dim())
            .map(|i| if self.lower[i] == self.upper[i] { 0.0 } else { (x[i] - self.offset[i]) / self.scale[i] })
            .collect()
    }

    /// Projects a scaled point into the box.
    pub fn project(&self, z: &mut [f64]) {
        for (i, v) in z.iter_mut().enumerate() {
            let (lo, hi) = self.z_bounds(i);
            *v = v.clamp(lo, hi);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounded_dimensions_map_to_the_unit_interval() {
        let s = Space::new(&[0.0, -1.0], &[10.0, f64::INFINITY], Some(&[5.0, 2.0]), None).unwrap();
        assert_eq!(s.to_scaled(&[5.0, 2.0]), vec![0.5, 1.0]);
        assert_eq!(s.to_user(&[0.5, 1.0]), vec![5.0, 2.0]);
        assert_eq!(s.to_user(&[1.5, -10.0]), vec![10.0, -1.0]);
        assert_eq!(s.z_bounds(0), (0.0, 1.0));
        assert_eq!(s.z_bounds(1), (-0.5, f64::INFINITY));
    }

    #[test]
    fn bad_settings_name_the_field() {
        let e = Space::new(&[1.0], &[0.0], None, None).unwrap_err();
        assert!(matches!(e, OptimError::Setting { field: "lower", .. }), "{e}");
        let e = Space::new(&[0.0], &[1.0], Some(&[2.0]), None).unwrap_err();
        assert!(matches!(e, OptimError::Setting { field: "x0", .. }), "{e}");
        let e = Space::new(&[f64::NEG_INFINITY], &[1.0], Some(&[0.0]), Some(&[-1.0])).unwrap_err();
        assert!(matches!(e, OptimError::Setting { field: "nominal", .. }), "{e}");
    }
}
