//! Standard test functions for the optimizers' tests and benchmarks: the Moré–Garbow–Hillstrom
//! set (ACM TOMS 7, 1981) with its standard starting points and minima, plus sphere, Rastrigin
//! and a problem whose optimum lies on a bound.

/// A test problem: objective, start, bounds for the bounded tests, and the known minimum.
#[derive(Debug, Clone, Copy)]
pub struct Problem {
    pub name: &'static str,
    pub f: fn(&[f64]) -> f64,
    pub x0: &'static [f64],
    /// Box for bounded tests (DE, GA); contains the minimizer.
    pub lower: &'static [f64],
    pub upper: &'static [f64],
    /// The minimum value the solvers are measured against.
    pub f_star: f64,
}

pub fn sphere(x: &[f64]) -> f64 {
    x.iter().map(|v| v * v).sum()
}

pub fn rosenbrock(x: &[f64]) -> f64 {
    x.windows(2).map(|w| 100.0 * (w[1] - w[0] * w[0]).powi(2) + (1.0 - w[0]).powi(2)).sum()
}

pub fn freudenstein_roth(x: &[f64]) -> f64 {
    let f1 = -13.0 + x[0] + ((5.0 - x[1]) * x[1] - 2.0) * x[1];
    let f2 = -29.0 + x[0] + ((x[1] + 1.0) * x[1] - 14.0) * x[1];
    f1 * f1 + f2 * f2
}

pub fn powell_badly_scaled(x: &[f64]) -> f64 {
    let f1 = 1e4 * x[0] * x[1] - 1.0;
    let f2 = (-x[0]).exp() + (-x[1]).exp() - 1.0001;
    f1 * f1 + f2 * f2
}

pub fn brown_badly_scaled(x: &[f64]) -> f64 {
    let f1 = x[0] - 1e6;
    let f2 = x[1] - 2e-6;
    let f3 = x[0] * x[1] - 2.0;
    f1 * f1 + f2 * f2 + f3 * f3
}

pub fn beale(x: &[f64]) -> f64 {
    [1.5, 2.25, 2.625].iter().enumerate().map(|(i, y)| (y - x[0] * (1.0 - x[1].powi(i as i32 + 1))).powi(2)).sum()
}

pub fn helical_valley(x: &[f64]) -> f64 {
    let theta = x[1].atan2(x[0]) / (2.0 * std::f64::consts::PI);
    let f1 = 10.0 * (x[2] - 10.0 * theta);
    let f2 = 10.0 * ((x[0] * x[0] + x[1] * x[1]).sqrt() - 1.0);
    f1 * f1 + f2 * f2 + x[2] * x[2]
}

pub fn powell_singular(x: &[f64]) -> f64 {
    (x[0] + 10.0 * x[1]).powi(2)
        + 5.0 * (x[2] - x[3]).powi(2)
        + (x[1] - 2.0 * x[2]).powi(4)
        + 10.0 * (x[0] - x[3]).powi(4)
}

pub fn wood(x: &[f64]) -> f64 {
    100.0 * (x[0] * x[0] - x[1]).powi(2)
        + (x[0] - 1.0).powi(2)
        + 90.0 * (x[2] * x[2] - x[3]).powi(2)
        + (1.0 - x[2]).powi(2)
        + 10.1 * ((x[1] - 1.0).powi(2) + (x[3] - 1.0).powi(2))
        + 19.8 * (x[1] - 1.0) * (x[3] - 1.0)
}

pub fn rastrigin(x: &[f64]) -> f64 {
    10.0 * x.len() as f64 + x.iter().map(|v| v * v - 10.0 * (2.0 * std::f64::consts::PI * v).cos()).sum::<f64>()
}

/// (x0 − 1)² + (x1 + 2)², minimised over [2, 5] × [−1, 3]: the optimum (2, −1) is a corner.
pub fn shifted_sphere(x: &[f64]) -> f64 {
    (x[0] - 1.0).powi(2) + (x[1] + 2.0).powi(2)
}

/// The Moré–Garbow–Hillstrom problems of the SciPy comparison. Freudenstein–Roth is measured
/// against its local minimum 48.9842…, where both implementations converge from the standard start.
pub const MGH: &[Problem] = &[
    Problem {
        name: "Rosenbrock",
        f: rosenbrock,
        x0: &[-1.2, 1.0],
        lower: &[-5.0, -5.0],
        upper: &[5.0, 5.0],
        f_star: 0.0,
    },
    Problem {
        name: "Freudenstein-Roth",
        f: freudenstein_roth,
        x0: &[0.5, -2.0],
        lower: &[-20.0, -20.0],
        upper: &[20.0, 20.0],
        f_star: 48.984_253_679_240_2,
    },
    Problem {
        name: "Powell badly scaled",
        f: powell_badly_scaled,
        x0: &[0.0, 1.0],
        lower: &[-1.0, 0.0],
        upper: &[1.0, 10.0],
        f_star: 0.0,
    },
    Problem {
        name: "Brown badly scaled",
        f: brown_badly_scaled,
        x0: &[1.0, 1.0],
        lower: &[0.0, 0.0],
        upper: &[2e6, 1.0],
        f_star: 0.0,
    },
    Problem { name: "Beale", f: beale, x0: &[1.0, 1.0], lower: &[-4.5, -4.5], upper: &[4.5, 4.5], f_star: 0.0 },
    Problem {
        name: "Helical valley",
        f: helical_valley,
        x0: &[-1.0, 0.0, 0.0],
        lower: &[-10.0, -10.0, -10.0],
        upper: &[10.0, 10.0, 10.0],
        f_star: 0.0,
    },
    Problem {
        name: "Powell singular",
        f: powell_singular,
        x0: &[3.0, -1.0, 0.0, 1.0],
        lower: &[-4.0, -4.0, -4.0, -4.0],
        upper: &[5.0, 5.0, 5.0, 5.0],
        f_star: 0.0,
    },
    Problem {
        name: "Wood",
        f: wood,
        x0: &[-3.0, -1.0, -3.0, -1.0],
        lower: &[-10.0, -10.0, -10.0, -10.0],
        upper: &[10.0, 10.0, 10.0, 10.0],
        f_star: 0.0,
    },
];

/// Asserts that `result` is an [`OptimError::Setting`](super::OptimError::Setting) naming `field`.
#[cfg(test)]
pub(crate) fn assert_names_setting<T: std::fmt::Debug>(result: Result<T, super::OptimError>, field: &str) {
    let e = result.unwrap_err();
    assert!(matches!(&e, super::OptimError::Setting { field: f, .. } if *f == field), "{e}");
}

/// Drives an optimizer on a plain function until it stops or `max_rounds` batches were asked.
/// Returns the number of rounds. Used by tests and benchmarks.
pub fn run(opt: &mut dyn super::Optimizer, f: &dyn Fn(&[f64]) -> super::Outcome, max_rounds: u64) -> u64 {
    let mut rounds = 0;
    while rounds < max_rounds {
        let batch = opt.ask();
        if batch.is_empty() {
            break;
        }
        rounds += 1;
        for c in batch {
            opt.tell(c.id, f(&c.x)).expect("tell a candidate that was asked");
        }
    }
    rounds
}
