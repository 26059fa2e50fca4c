//! Least-squares test problems as residual vectors, for the least-squares solver's tests and
//! benchmark:
//! - [`MGH_LS`]: Moré–Garbow–Hillstrom problems (ACM TOMS 7, 1981), unbounded: the eight of
//!   [`test_problems::MGH`](super::test_problems::MGH) in residual form and ten more, most with
//!   more residuals than parameters (m > n), each with MGH's standard start;
//! - [`CALIBRATION`]: two small bounded calibrations of the kind fmucal runs (two parameters
//!   of a smooth model fitted to 40–100 noisy samples).
//!
//! Each has a known minimiser and minimum f* = Σ r² (the minimisers of the problems with
//! f* > 0 were refined with SciPy's `least_squares`; the MGH ones agree with MGH's f* to the
//! digits MGH gives).

/// A least-squares test problem.
#[derive(Debug, Clone, Copy)]
pub struct LsProblem {
    pub name: &'static str,
    pub residuals: fn(&[f64]) -> Vec<f64>,
    pub x0: &'static [f64],
    /// A minimiser the solvers reach from `x0` (for Freudenstein–Roth the local one).
    pub x_star: &'static [f64],
    /// Σ r² at `x_star`.
    pub f_star: f64,
    /// Lower and upper bounds, for a bounded problem.
    pub bounds: Option<(&'static [f64], &'static [f64])>,
}

impl LsProblem {
    /// f = Σ r².
    pub fn f(&self, x: &[f64]) -> f64 {
        (self.residuals)(x).iter().map(|r| r * r).sum()
    }

    /// Number of residuals.
    pub fn m(&self) -> usize {
        (self.residuals)(self.x0).len()
    }
}

pub fn rosenbrock(x: &[f64]) -> Vec<f64> {
    vec![10.0 * (x[1] - x[0] * x[0]), 1.0 - x[0]]
}

pub fn freudenstein_roth(x: &[f64]) -> Vec<f64> {
    vec![-13.0 + x[0] + ((5.0 - x[1]) * x[1] - 2.0) * x[1], -29.0 + x[0] + ((x[1] + 1.0) * x[1] - 14.0) * x[1]]
}

pub fn powell_badly_scaled(x: &[f64]) -> Vec<f64> {
    vec![1e4 * x[0] * x[1] - 1.0, (-x[0]).exp() + (-x[1]).exp() - 1.0001]
}

pub fn brown_badly_scaled(x: &[f64]) -> Vec<f64> {
    vec![x[0] - 1e6, x[1] - 2e-6, x[0] * x[1] - 2.0]
}

pub fn beale(x: &[f64]) -> Vec<f64> {
    [1.5, 2.25, 2.625].iter().enumerate().map(|(i, y)| y - x[0] * (1.0 - x[1].powi(i as i32 + 1))).collect()
}

/// m = 10.
pub fn jennrich_sampson(x: &[f64]) -> Vec<f64> {
    (1..=10).map(f64::from).map(|i| 2.0 + 2.0 * i - ((i * x[0]).exp() + (i * x[1]).exp())).collect()
}

pub fn helical_valley(x: &[f64]) -> Vec<f64> {
    let theta = x[1].atan2(x[0]) / (2.0 * std::f64::consts::PI);
    vec![10.0 * (x[2] - 10.0 * theta), 10.0 * ((x[0] * x[0] + x[1] * x[1]).sqrt() - 1.0), x[2]]
}

const BARD_Y: [f64; 15] = [0.14, 0.18, 0.22, 0.25, 0.29, 0.32, 0.35, 0.39, 0.37, 0.58, 0.73, 0.96, 1.34, 2.10, 4.39];

pub fn bard(x: &[f64]) -> Vec<f64> {
    BARD_Y
        .iter()
        .enumerate()
        .map(|(k, y)| {
            let u = (k + 1) as f64;
            let v = 16.0 - u;
            y - (x[0] + u / (v * x[1] + u.min(v) * x[2]))
        })
        .collect()
}

const GAUSSIAN_Y: [f64; 15] = [
    0.0009, 0.0044, 0.0175, 0.0540, 0.1295, 0.2420, 0.3521, 0.3989, 0.3521, 0.2420, 0.1295, 0.0540, 0.0175, 0.0044,
    0.0009,
];

pub fn gaussian(x: &[f64]) -> Vec<f64> {
    GAUSSIAN_Y
        .iter()
        .enumerate()
        .map(|(k, y)| {
            let t = (8.0 - (k + 1) as f64) / 2.0;
            x[0] * (-x[1] * (t - x[2]).powi(2) / 2.0).exp() - y
        })
        .collect()
}

const MEYER_Y: [f64; 16] = [
    34780.0, 28610.0, 23650.0, 19630.0, 16370.0, 13720.0, 11540.0, 9744.0, 8261.0, 7030.0, 6005.0, 5147.0, 4427.0,
    3820.0, 3307.0, 2872.0,
];

pub fn meyer(x: &[f64]) -> Vec<f64> {
    MEYER_Y
        .iter()
        .enumerate()
        .map(|(k, y)| {
            let t = 45.0 + 5.0 * (k + 1) as f64;
            x[0] * (x[1] / (t + x[2])).exp() - y
        })
        .collect()
}

/// m = 10.
pub fn box_3d(x: &[f64]) -> Vec<f64> {
    (1..=10)
        .map(|i| 0.1 * f64::from(i))
        .map(|t| (-t * x[0]).exp() - (-t * x[1]).exp() - x[2] * ((-t).exp() - (-10.0 * t).exp()))
        .collect()
}

pub fn powell_singular(x: &[f64]) -> Vec<f64> {
    vec![
        x[0] + 10.0 * x[1],
        5f64.sqrt() * (x[2] - x[3]),
        (x[1] - 2.0 * x[2]).powi(2),
        10f64.sqrt() * (x[0] - x[3]).powi(2),
    ]
}

pub fn wood(x: &[f64]) -> Vec<f64> {
    vec![
        10.0 * (x[1] - x[0] * x[0]),
        1.0 - x[0],
        90f64.sqrt() * (x[3] - x[2] * x[2]),
        1.0 - x[2],
        10f64.sqrt() * (x[1] + x[3] - 2.0),
        (x[1] - x[3]) / 10f64.sqrt(),
    ]
}

const KOWALIK_Y: [f64; 11] = [0.1957, 0.1947, 0.1735, 0.1600, 0.0844, 0.0627, 0.0456, 0.0342, 0.0323, 0.0235, 0.0246];
const KOWALIK_U: [f64; 11] = [4.0, 2.0, 1.0, 0.5, 0.25, 0.167, 0.125, 0.1, 0.0833, 0.0714, 0.0625];

pub fn kowalik_osborne(x: &[f64]) -> Vec<f64> {
    KOWALIK_Y.iter().zip(KOWALIK_U).map(|(y, u)| y - x[0] * (u * u + u * x[1]) / (u * u + u * x[2] + x[3])).collect()
}

/// m = 20.
pub fn brown_dennis(x: &[f64]) -> Vec<f64> {
    (1..=20)
        .map(|i| f64::from(i) / 5.0)
        .map(|t| (x[0] + t * x[1] - t.exp()).powi(2) + (x[2] + x[3] * t.sin() - t.cos()).powi(2))
        .collect()
}

const OSBORNE1_Y: [f64; 33] = [
    0.844, 0.908, 0.932, 0.936, 0.925, 0.908, 0.881, 0.850, 0.818, 0.784, 0.751, 0.718, 0.685, 0.658, 0.628, 0.603,
    0.580, 0.558, 0.538, 0.522, 0.506, 0.490, 0.478, 0.467, 0.457, 0.448, 0.438, 0.431, 0.424, 0.420, 0.414, 0.411,
    0.406,
];

pub fn osborne_1(x: &[f64]) -> Vec<f64> {
    OSBORNE1_Y
        .iter()
        .enumerate()
        .map(|(k, y)| {
            let t = 10.0 * k as f64;
            y - (x[0] + x[1] * (-t * x[3]).exp() + x[2] * (-t * x[4]).exp())
        })
        .collect()
}

/// m = 13.
pub fn biggs_exp6(x: &[f64]) -> Vec<f64> {
    (1..=13)
        .map(|i| 0.1 * f64::from(i))
        .map(|t| {
            let y = (-t).exp() - 5.0 * (-10.0 * t).exp() + 3.0 * (-4.0 * t).exp();
            x[2] * (-t * x[0]).exp() - x[3] * (-t * x[1]).exp() + x[5] * (-t * x[4]).exp() - y
        })
        .collect()
}

/// Any n; m = n + 1.
pub fn penalty_1(x: &[f64]) -> Vec<f64> {
    let a = 1e-5f64.sqrt();
    let mut r: Vec<f64> = x.iter().map(|v| a * (v - 1.0)).collect();
    r.push(x.iter().map(|v| v * v).sum::<f64>() - 0.25);
    r
}

/// The problems, in MGH's order within the two groups: the eight of `test_problems::MGH`
/// (except that Jennrich–Sampson joins them), then those with m > n.
pub const MGH_LS: &[LsProblem] = &[
    LsProblem {
        name: "Rosenbrock",
        residuals: rosenbrock,
        x0: &[-1.2, 1.0],
        x_star: &[1.0, 1.0],
        f_star: 0.0,
        bounds: None,
    },
    LsProblem {
        name: "Freudenstein-Roth",
        residuals: freudenstein_roth,
        x0: &[0.5, -2.0],
        x_star: &[11.412_779_178_876_189, -0.896_805_240_463_142_1],
        f_star: 48.984_253_679_240_2,
        bounds: None,
    },
    LsProblem {
        name: "Powell badly scaled",
        residuals: powell_badly_scaled,
        x0: &[0.0, 1.0],
        x_star: &[1.098_159_329_699_714_7e-5, 9.106_146_739_867_377],
        f_star: 0.0,
        bounds: None,
    },
    LsProblem {
        name: "Brown badly scaled",
        residuals: brown_badly_scaled,
        x0: &[1.0, 1.0],
        x_star: &[1e6, 2e-6],
        f_star: 0.0,
        bounds: None,
    },
    LsProblem { name: "Beale", residuals: beale, x0: &[1.0, 1.0], x_star: &[3.0, 0.5], f_star: 0.0, bounds: None },
    LsProblem {
        name: "Jennrich-Sampson",
        residuals: jennrich_sampson,
        x0: &[0.3, 0.4],
        x_star: &[0.257_825_211_873_381_7, 0.257_825_214_845_229_6],
        f_star: 124.362_182_355_6,
        bounds: None,
    },
    LsProblem {
        name: "Helical valley",
        residuals: helical_valley,
        x0: &[-1.0, 0.0, 0.0],
        x_star: &[1.0, 0.0, 0.0],
        f_star: 0.0,
        bounds: None,
    },
    LsProblem {
        name: "Bard",
        residuals: bard,
        x0: &[1.0, 1.0, 1.0],
        x_star: &[0.082_410_559_919_102_39, 1.133_036_097_526_684_4, 2.343_695_173_380_824_2],
        f_star: 8.214_877_306_579e-3,
        bounds: None,
    },
    LsProblem {
        name: "Gaussian",
        residuals: gaussian,
        x0: &[0.4, 1.0, 0.0],
        x_star: &[0.398_956_137_838_552_44, 1.000_019_084_485_868_7, 0.0],
        f_star: 1.127_932_769_619e-8,
        bounds: None,
    },
    LsProblem {
        name: "Meyer",
        residuals: meyer,
        x0: &[0.02, 4000.0, 250.0],
        x_star: &[5.609_636_739_923_597e-3, 6_181.346_306_306_41, 345.223_633_277_771_9],
        f_star: 87.945_855_170_52,
        bounds: None,
    },
    LsProblem {
        name: "Box 3-D",
        residuals: box_3d,
        x0: &[0.0, 10.0, 20.0],
        x_star: &[1.0, 10.0, 1.0],
        f_star: 0.0,
        bounds: None,
    },
    LsProblem {
        name: "Powell singular",
        residuals: powell_singular,
        x0: &[3.0, -1.0, 0.0, 1.0],
        x_star: &[0.0, 0.0, 0.0, 0.0],
        f_star: 0.0,
        bounds: None,
    },
    LsProblem {
        name: "Wood",
        residuals: wood,
        x0: &[-3.0, -1.0, -3.0, -1.0],
        x_star: &[1.0, 1.0, 1.0, 1.0],
        f_star: 0.0,
        bounds: None,
    },
    LsProblem {
        name: "Kowalik-Osborne",
        residuals: kowalik_osborne,
        x0: &[0.25, 0.39, 0.415, 0.39],
        x_star: &[
            0.192_806_935_156_890_65,
            0.191_282_312_050_115_5,
            0.123_056_501_802_555_98,
            0.136_062_323_321_379_08,
        ],
        f_star: 3.075_056_038_492e-4,
        bounds: None,
    },
    LsProblem {
        name: "Brown-Dennis",
        residuals: brown_dennis,
        x0: &[25.0, 5.0, -5.0, -1.0],
        x_star: &[-11.594_439_317_837_942, 13.203_629_820_872_228, -0.403_439_583_954_027_7, 0.236_779_112_794_021_53],
        f_star: 85_822.201_626_36,
        bounds: None,
    },
    LsProblem {
        name: "Osborne 1",
        residuals: osborne_1,
        x0: &[0.5, 1.5, -1.0, 0.01, 0.02],
        x_star: &[
            0.375_410_051_387_024_43,
            1.935_846_828_651_541_8,
            -1.464_687_052_033_090_4,
            0.012_867_534_469_821_31,
            0.022_122_700_002_951_99,
        ],
        f_star: 5.464_894_697_482e-5,
        bounds: None,
    },
    LsProblem {
        name: "Biggs EXP6",
        residuals: biggs_exp6,
        x0: &[1.0, 2.0, 1.0, 1.0, 1.0, 1.0],
        x_star: &[1.0, 10.0, 1.0, 5.0, 4.0, 3.0],
        f_star: 0.0,
        bounds: None,
    },
    LsProblem {
        name: "Penalty I",
        residuals: penalty_1,
        x0: &[1.0, 2.0, 3.0, 4.0],
        x_star: &[
            0.250_007_499_854_390_47,
            0.250_007_500_183_110_74,
            0.250_007_498_457_476_6,
            0.250_007_499_854_404_24,
        ],
        f_star: 2.249_977_500_900e-5,
        bounds: None,
    },
];

/// A deterministic stand-in for measurement noise in [−1, 1): the fractional parts of i·φ⁻¹.
fn noise(i: usize) -> f64 {
    ((i as f64 * 0.618_033_988_749_894_9) % 1.0 - 0.5) * 2.0
}

/// Displacement of a unit mass on a spring of stiffness k with damping d after a unit force
/// step at t = 0 (underdamped).
fn spring_step(k: f64, d: f64, t: f64) -> f64 {
    let w = k.sqrt();
    let z = d / (2.0 * w);
    let wd = w * (1.0 - z * z).sqrt();
    (1.0 - (-z * w * t).exp() * ((wd * t).cos() + z * w / wd * (wd * t).sin())) / k
}

/// Spring–damper calibration: stiffness and damping (true 4 and 0.8) from 100 samples of the
/// step response over 10 s, with noise of ±0.002 (the response settles at 0.25).
pub fn spring_damper(x: &[f64]) -> Vec<f64> {
    (1..=100)
        .map(|i| {
            let t = 0.1 * i as f64;
            spring_step(x[0], x[1], t) - (spring_step(4.0, 0.8, t) + 0.002 * noise(i))
        })
        .collect()
}

/// Logistic growth K / (1 + (K/0.5 − 1) e^(−r t)) from 0.5.
fn logistic(k: f64, r: f64, t: f64) -> f64 {
    k / (1.0 + (k / 0.5 - 1.0) * (-r * t).exp())
}

/// Logistic-growth calibration: capacity and rate (true 8 and 0.6) from 40 samples over 20 s
/// with 1 % multiplicative noise.
pub fn logistic_growth(x: &[f64]) -> Vec<f64> {
    (1..=40)
        .map(|i| {
            let t = 0.5 * i as f64;
            logistic(x[0], x[1], t) - logistic(8.0, 0.6, t) * (1.0 + 0.01 * noise(i + 100))
        })
        .collect()
}

const MM_SUBSTRATE: [f64; 20] =
    [0.02, 0.04, 0.06, 0.08, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 7.5, 10.0, 15.0];

/// Michaelis–Menten kinetics V s / (K + s): maximal rate and half-saturation constant (true
/// 2.5 and 0.7) from 20 rates with noise of ±0.02.
pub fn michaelis_menten(x: &[f64]) -> Vec<f64> {
    MM_SUBSTRATE
        .iter()
        .enumerate()
        .map(|(k, s)| x[0] * s / (x[1] + s) - (2.5 * s / (0.7 + s) + 0.02 * noise(k + 1 + 200)))
        .collect()
}

/// Free vibration e^(−ζωt) cos(ω √(1−ζ²) t) from unit displacement.
fn vibration(w: f64, z: f64, t: f64) -> f64 {
    (-z * w * t).exp() * (w * (1.0 - z * z).sqrt() * t).cos()
}

/// Free-vibration calibration: natural frequency and damping ratio (true 3 and 0.15) from 120
/// samples over 6 s with noise of ±0.01.
pub fn free_vibration(x: &[f64]) -> Vec<f64> {
    (1..=120)
        .map(|i| {
            let t = 0.05 * i as f64;
            vibration(x[0], x[1], t) - (vibration(3.0, 0.15, t) + 0.01 * noise(i + 300))
        })
        .collect()
}

/// Two-parameter calibrations in boxes, from starts inside the box but away from the optimum.
pub const CALIBRATION: &[LsProblem] = &[
    LsProblem {
        name: "Spring-damper step",
        residuals: spring_damper,
        x0: &[5.5, 1.5],
        x_star: &[3.999_759_189_611_644, 0.799_504_088_329_691_6],
        f_star: 1.320_610_999_721_12e-4,
        bounds: Some((&[1.0, 0.1], &[10.0, 3.0])),
    },
    LsProblem {
        name: "Logistic growth",
        residuals: logistic_growth,
        x0: &[5.0, 1.0],
        x_star: &[7.999_289_398_510_461, 0.600_331_842_229_506_4],
        f_star: 5.884_446_643_204_176e-2,
        bounds: Some((&[1.0, 0.05], &[20.0, 3.0])),
    },
    LsProblem {
        name: "Michaelis-Menten",
        residuals: michaelis_menten,
        x0: &[1.0, 2.0],
        x_star: &[2.504_354_628_883_328, 0.704_925_191_177_111_4],
        f_star: 2.693_169_646_171_598e-3,
        bounds: Some((&[0.1, 0.01], &[10.0, 10.0])),
    },
    LsProblem {
        name: "Free vibration",
        residuals: free_vibration,
        x0: &[2.6, 0.3],
        x_star: &[3.000_115_644_500_369_6, 0.149_784_637_166_283_65],
        f_star: 4.012_819_003_604_208e-3,
        bounds: Some((&[1.0, 0.01], &[5.0, 0.9])),
    },
];

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_problems::MGH;

    #[test]
    fn each_problem_has_its_known_minimum_at_its_minimiser() {
        assert!(MGH_LS.len() >= 14);
        for p in MGH_LS.iter().chain(CALIBRATION) {
            assert_eq!(p.x_star.len(), p.x0.len(), "{}", p.name);
            let f = p.f(p.x_star);
            let tol = 1e-9 * (1.0 + p.f_star) + 1e-20;
            assert!((f - p.f_star).abs() <= tol, "{}: f(x*) = {f:e}, f* = {:e}", p.name, p.f_star);
            assert!(p.f(p.x0) > p.f_star, "{}", p.name);
        }
        let with_more_residuals = MGH_LS.iter().filter(|p| p.m() > p.x0.len()).count();
        assert!(with_more_residuals >= 6 + 3, "{with_more_residuals}");
    }

    #[test]
    fn the_residual_forms_sum_to_the_scalar_mgh_functions() {
        for q in MGH {
            let p = MGH_LS.iter().find(|p| p.name == q.name).expect("every scalar MGH problem has a residual form");
            assert_eq!(p.x0, q.x0);
            for x in [q.x0, p.x_star, &[0.3, -0.7, 1.1, 2.0][..q.x0.len()]] {
                let (a, b) = (p.f(x), (q.f)(x));
                assert!((a - b).abs() <= 1e-12 * (1.0 + b.abs()), "{}: {a} vs {b} at {x:?}", p.name);
            }
            assert!((p.f_star - q.f_star).abs() <= 1e-12 * (1.0 + q.f_star), "{}", p.name);
        }
    }

    /// Values at the standard starts, as the DFO-LS benchmark script computes them.
    #[test]
    fn values_at_the_starts_match_the_python_definitions() {
        let expected = [
            ("Rosenbrock", 24.2),
            ("Jennrich-Sampson", 4_171.306_161_960_493),
            ("Bard", 41.681_695_861_678_01),
            ("Meyer", 1_693_607_809.436_145_5),
            ("Osborne 1", 0.879_026_293_544_640_2),
            ("Penalty I", 885.062_64),
            ("Spring-damper step", 0.580_399_761_948_232_5),
            ("Logistic growth", 219.633_164_463_095_74),
            ("Michaelis-Menten", 21.090_760_656_275_148),
            ("Free vibration", 3.439_914_559_869_257_5),
        ];
        for (name, f0) in expected {
            let p = MGH_LS.iter().chain(CALIBRATION).find(|p| p.name == name).expect("problem");
            assert!((p.f(p.x0) - f0).abs() <= 1e-9 * f0, "{name}: {}", p.f(p.x0));
        }
    }
}
