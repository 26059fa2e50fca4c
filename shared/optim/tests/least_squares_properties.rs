//! Property tests of the least-squares solver (proptest), as `optim_properties.rs` does for the
//! other optimizers: no asked point leaves the bounds, serialize/resume equals never stopping,
//! the order of tells within a batch does not change the trajectory, failed, NaN and infinite
//! residuals never cause panics, and no run asks more than `max_fevals` evaluations.

mod support;

use fmucal_optim::{Candidate, LeastSquares, LsSettings, Optimizer, Status, Stopping};
use proptest::prelude::*;

#[derive(Debug, Clone)]
struct Case {
    lower: Vec<f64>,
    upper: Vec<f64>,
    x0: Vec<f64>,
    initial_radius: f64,
}

/// Boxes of 1 to 4 parameters, some bounded on one side only, some with x0 on a bound.
fn case() -> impl Strategy<Value = Case> {
    (1usize..5, prop_oneof![Just(0.1), 0.01f64..0.6])
        .prop_flat_map(|(n, initial_radius)| {
            (
                prop::collection::vec(
                    (-10.0f64..10.0, 1e-3f64..20.0, prop_oneof![Just(0.0), Just(1.0), 0.0f64..=1.0], 0u8..5),
                    n,
                ),
                Just(initial_radius),
            )
        })
        .prop_map(|(dims, initial_radius)| {
            let mut c = Case { lower: vec![], upper: vec![], x0: vec![], initial_radius };
            for (l, w, frac, open) in dims {
                let u = l + w;
                c.x0.push(l + frac * w);
                c.lower.push(if open == 0 { f64::NEG_INFINITY } else { l });
                c.upper.push(if open == 1 { f64::INFINITY } else { u });
            }
            c
        })
}

/// A deterministic, nonlinear residual vector (2n + 1 entries) that fails at about one point
/// in seven.
fn residuals(x: &[f64]) -> Option<Vec<f64>> {
    if support::fails_at(x) {
        return None;
    }
    let mut r: Vec<f64> = x.iter().map(|v| (v - 0.3) + 0.1 * (13.0 * v).sin()).collect();
    r.extend(x.windows(2).map(|w| w[0] * w[1] - 1.0));
    r.extend(x.iter().map(|v| 0.5 * v * v - 2.0));
    r.push(x.iter().sum::<f64>().cos());
    Some(r)
}

fn build(c: &Case, max_fevals: Option<u64>) -> LeastSquares {
    let n = c.x0.len();
    let mut settings = LsSettings { initial_radius: c.initial_radius, ..LsSettings::new(n) };
    settings.stopping.max_fevals = max_fevals;
    LeastSquares::new(&c.lower, &c.upper, &c.x0, settings).expect("valid settings")
}

/// Runs `rounds` batches, telling each in the order given by `order_seed`, and returns every
/// batch asked.
fn drive(opt: &mut dyn Optimizer, rounds: usize, order_seed: u64) -> Vec<Vec<Candidate>> {
    support::drive(opt, rounds, order_seed, |opt, c| {
        opt.tell_residuals(c.id, residuals(&c.x).as_deref()).expect("tell an asked candidate")
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn no_asked_point_leaves_the_bounds(c in case()) {
        let mut opt = build(&c, None);
        support::within_bounds(&drive(&mut opt, 60, 0), &c.lower, &c.upper)?;
    }

    #[test]
    fn serialize_resume_equals_uninterrupted(c in case(), split in 1usize..20) {
        let mut a = build(&c, None);
        let head = drive(&mut a, split, 0);
        prop_assert!(!head.is_empty());
        let json = serde_json::to_string(&a).expect("serialize");
        let mut b: LeastSquares = serde_json::from_str(&json).expect("deserialize");
        prop_assert_eq!(serde_json::to_string(&b).expect("serialize"), json);
        prop_assert_eq!(drive(&mut a, 40, 0), drive(&mut b, 40, 0));
        prop_assert_eq!((a.status(), a.best(), a.evaluations(), a.rounds()), (b.status(), b.best(), b.evaluations(), b.rounds()));
    }

    #[test]
    fn any_order_of_tells_gives_the_same_trajectory(c in case(), order in 1u64..u64::MAX) {
        let in_order = drive(&mut build(&c, None), 40, 0);
        let shuffled = drive(&mut build(&c, None), 40, order);
        prop_assert_eq!(in_order, shuffled);
    }

    #[test]
    fn failures_nan_and_infinities_never_panic(c in case(), pattern in prop::collection::vec(0u8..5, 1..50)) {
        let mut opt = build(&c, None);
        support::tell_by_pattern(
            &mut opt,
            80,
            &pattern,
            |opt, cand, choice| {
                let r = residuals(&cand.x);
                let told = match choice {
                    0 => None,
                    1 => r.map(|mut r| { r[0] = f64::NAN; r }),
                    2 => r.map(|mut r| { r[0] = f64::NEG_INFINITY; r }),
                    3 => r.map(|r| r.iter().map(|v| v * 1e200).collect()),
                    _ => r,
                };
                opt.tell_residuals(cand.id, told.as_deref()).expect("tell an asked candidate");
            },
            |_| Ok(()),
        )?;
        if let Some((x, f)) = opt.best() {
            prop_assert!(f.is_finite() && f >= 0.0);
            prop_assert!(x.iter().all(|v| v.is_finite()));
        }
    }

    #[test]
    fn never_asks_more_than_max_fevals(c in case(), max in 1u64..40) {
        let mut opt = build(&c, Some(max));
        let asked: usize = drive(&mut opt, 1000, 0).iter().map(Vec::len).sum();
        prop_assert!(asked as u64 <= max, "{} asked, max_fevals {}", asked, max);
        prop_assert_eq!(opt.evaluations(), asked as u64);
        prop_assert!(matches!(opt.status(), Status::Done(_)));
        prop_assert!(opt.ask().is_empty());
    }
}

#[test]
fn every_run_ends_within_its_default_limits() {
    // Without max_fevals, the default rules (x_tol, slow progress, max_iters) end every run.
    let c =
        Case { lower: vec![-1.0, f64::NEG_INFINITY], upper: vec![1.0, 5.0], x0: vec![0.2, 1.0], initial_radius: 0.1 };
    let mut opt = build(&c, None);
    drive(&mut opt, 100_000, 0);
    assert!(matches!(opt.status(), Status::Done(_)), "{:?}", opt.status());
    let stopping = Stopping::default_for(2);
    assert!(opt.iterations() < stopping.max_iters.unwrap_or(u64::MAX));
}
