//! Property tests of CMA-ES (proptest), as `optim_properties.rs` has them for the other
//! optimizers: no asked point leaves the bounds, serialize/resume equals never stopping, the
//! order of tells does not change the trajectory, failed, NaN and infinite results never cause
//! panics, and `max_fevals` is never exceeded. Cases include fixed parameters (lower = upper),
//! small and large σ₀, and a loose x_tol so that the IPOP restarts happen within the rounds run.

mod support;

use fmucal_optim::{Candidate, CmaEs, CmaSettings, Optimizer, Outcome, Status, Termination};
use proptest::prelude::*;

#[derive(Debug, Clone)]
struct Case {
    lower: Vec<f64>,
    upper: Vec<f64>,
    x0: Vec<f64>,
    settings: CmaSettings,
}

fn case() -> impl Strategy<Value = Case> {
    (1usize..5)
        .prop_flat_map(|n| {
            (
                prop::collection::vec((-10.0f64..10.0, 1e-3f64..20.0, 0.0f64..=1.0, prop::bool::weighted(0.15)), n),
                any::<u64>(),
                4usize..12,
                prop_oneof![Just(0.3), 1e-3f64..2.0],
                0u32..4,
                prop_oneof![Just(None), (1e-3f64..0.1).prop_map(Some)],
            )
        })
        .prop_map(|(dims, seed, population, sigma0, restarts, x_tol)| {
            let n = dims.len();
            let mut settings = CmaSettings { population, sigma0, restarts, seed, ..CmaSettings::new(n) };
            settings.stopping.x_tol = x_tol.or(settings.stopping.x_tol);
            let mut c = Case { lower: vec![], upper: vec![], x0: vec![], settings };
            for (l, w, frac, fixed) in dims {
                let u = if fixed { l } else { l + w };
                c.x0.push(l + frac * (u - l));
                c.lower.push(l);
                c.upper.push(u);
            }
            c
        })
}

fn build(c: &Case) -> CmaEs {
    CmaEs::new(&c.lower, &c.upper, Some(&c.x0), c.settings.clone()).unwrap()
}

/// Runs `rounds` batches, telling each in the order given by `order_seed`, and returns every
/// batch asked.
fn drive(opt: &mut dyn Optimizer, rounds: usize, order_seed: u64) -> Vec<Vec<Candidate>> {
    support::drive(opt, rounds, order_seed, |opt, c| opt.tell(c.id, support::objective(&c.x)).unwrap())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn no_asked_point_leaves_the_bounds(c in case()) {
        let mut opt = build(&c);
        support::within_bounds(&drive(&mut opt, 60, 0), &c.lower, &c.upper)?;
    }

    #[test]
    fn serialize_resume_equals_uninterrupted(c in case(), split in 1usize..25) {
        let mut a = build(&c);
        let head = drive(&mut a, split, 0);
        let json = serde_json::to_string(&a).unwrap();
        let mut b: CmaEs = serde_json::from_str(&json).unwrap();
        prop_assert_eq!(serde_json::to_string(&b).unwrap(), json);
        prop_assert_eq!(drive(&mut a, 40, 0), drive(&mut b, 40, 0));
        prop_assert_eq!((a.best(), a.status()), (b.best(), b.status()));
        prop_assert!(!head.is_empty());
    }

    #[test]
    fn the_same_seed_and_any_order_of_tells_give_the_same_trajectory(c in case(), order in 1u64..u64::MAX) {
        let in_order = drive(&mut build(&c), 40, 0);
        let shuffled = drive(&mut build(&c), 40, order);
        prop_assert_eq!(in_order, shuffled);
    }

    #[test]
    fn failures_nan_and_infinities_never_panic(c in case(), pattern in prop::collection::vec(0u8..5, 1..50)) {
        let mut opt = build(&c);
        support::tell_by_pattern(
            &mut opt,
            80,
            &pattern,
            |opt, cand, choice| opt.tell(cand.id, support::hostile_outcome(choice, &cand.x)).unwrap(),
            |opt| {
                // The state stays serializable whatever was told.
                let json = serde_json::to_string(opt).unwrap();
                prop_assert!(serde_json::from_str::<CmaEs>(&json).is_ok());
                Ok(())
            },
        )?;
        support::best_is_finite(&opt)?;
    }

    #[test]
    fn max_fevals_is_never_exceeded(c in case(), max_fevals in 1u64..400) {
        let mut settings = c.settings.clone();
        settings.stopping.max_fevals = Some(max_fevals);
        let mut opt = CmaEs::new(&c.lower, &c.upper, Some(&c.x0), settings).unwrap();
        let asked: usize = drive(&mut opt, 10_000, 0).iter().map(Vec::len).sum();
        prop_assert!(asked as u64 <= max_fevals && opt.evaluations() == asked as u64);
        prop_assert!(matches!(opt.status(), Status::Done(_)), "{:?}", opt.status());
        if opt.status() == Status::Done(Termination::MaxFevals) {
            prop_assert_eq!(opt.evaluations(), max_fevals);
        }
    }
}

#[test]
fn telling_an_unknown_or_repeated_id_is_an_error() {
    let mut es = CmaEs::new(&[0.0], &[1.0], Some(&[0.5]), CmaSettings::new(1)).unwrap();
    let batch = es.ask();
    assert!(es.tell(9999, Outcome::Value(1.0)).is_err());
    es.tell(batch[0].id, Outcome::Value(1.0)).unwrap();
    assert!(es.tell(batch[0].id, Outcome::Value(1.0)).is_err());
    assert_eq!(es.ask().len(), batch.len() - 1, "asking again returns only the open candidates");
}
