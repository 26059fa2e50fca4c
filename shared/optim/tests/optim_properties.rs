//! Property tests of the ask/tell optimizers (proptest): no asked point leaves the bounds,
//! serialize/resume equals never stopping, the order of tells does not change the trajectory,
//! and failed or NaN results never cause panics.

mod support;

use fmucal_optim::{
    Candidate, DeSettings, DifferentialEvolution, GaSettings, GeneticAlgorithm, NelderMead, NmSettings, Optimizer,
    Outcome,
};
use proptest::prelude::*;
use serde::Serialize;
use serde::de::DeserializeOwned;

#[derive(Debug, Clone, Copy)]
enum Kind {
    NmParallel,
    NmSequential,
    De,
    Ga,
}

#[derive(Debug, Clone)]
struct Case {
    kind: Kind,
    lower: Vec<f64>,
    upper: Vec<f64>,
    x0: Vec<f64>,
    seed: u64,
}

fn case() -> impl Strategy<Value = Case> {
    (
        1usize..4,
        any::<u64>(),
        prop_oneof![Just(Kind::NmParallel), Just(Kind::NmSequential), Just(Kind::De), Just(Kind::Ga)],
    )
        .prop_flat_map(|(n, seed, kind)| {
            let unbounded_ok = matches!(kind, Kind::NmParallel | Kind::NmSequential);
            (
                prop::collection::vec((-10.0f64..10.0, 1e-3f64..20.0, 0.0f64..=1.0, prop::bool::weighted(0.2)), n),
                Just(seed),
                Just(kind),
                Just(unbounded_ok),
            )
        })
        .prop_map(|(dims, seed, kind, unbounded_ok)| {
            let mut c = Case { kind, lower: vec![], upper: vec![], x0: vec![], seed };
            for (l, w, frac, open) in dims {
                let u = l + w;
                c.x0.push(l + frac * w);
                let open = open && unbounded_ok;
                c.lower.push(if open { f64::NEG_INFINITY } else { l });
                c.upper.push(u);
            }
            c
        })
}

fn nm_settings(n: usize, parallel: bool) -> NmSettings {
    NmSettings { parallel, ..NmSettings::new(n) }
}

/// Runs `rounds` batches, telling each in the order given by `order_seed`, and returns every
/// batch asked.
fn drive(opt: &mut dyn Optimizer, rounds: usize, order_seed: u64) -> Vec<Vec<Candidate>> {
    support::drive(opt, rounds, order_seed, |opt, c| opt.tell(c.id, support::objective(&c.x)).unwrap())
}

fn build(c: &Case) -> Box<dyn Optimizer> {
    let n = c.x0.len();
    match c.kind {
        Kind::NmParallel => Box::new(NelderMead::new(&c.lower, &c.upper, &c.x0, nm_settings(n, true)).unwrap()),
        Kind::NmSequential => Box::new(NelderMead::new(&c.lower, &c.upper, &c.x0, nm_settings(n, false)).unwrap()),
        Kind::De => Box::new(
            DifferentialEvolution::new(
                &c.lower,
                &c.upper,
                Some(&c.x0),
                DeSettings { seed: c.seed, ..DeSettings::new(n) },
            )
            .unwrap(),
        ),
        Kind::Ga => Box::new(
            GeneticAlgorithm::new(&c.lower, &c.upper, Some(&c.x0), GaSettings { seed: c.seed, ..GaSettings::new(n) })
                .unwrap(),
        ),
    }
}

fn resume_matches<T: Optimizer + Serialize + DeserializeOwned>(
    mut a: T,
    split: usize,
    total: usize,
) -> Result<(), TestCaseError> {
    let head = drive(&mut a, split, 0);
    let json = serde_json::to_string(&a).unwrap();
    let mut b: T = serde_json::from_str(&json).unwrap();
    let tail_a = drive(&mut a, total - split, 0);
    let tail_b = drive(&mut b, total - split, 0);
    prop_assert_eq!(tail_a, tail_b);
    prop_assert!(!head.is_empty());
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn no_asked_point_leaves_the_bounds(c in case()) {
        let mut opt = build(&c);
        support::within_bounds(&drive(opt.as_mut(), 40, 0), &c.lower, &c.upper)?;
    }

    #[test]
    fn serialize_resume_equals_uninterrupted(c in case(), split in 1usize..15) {
        let n = c.x0.len();
        match c.kind {
            Kind::NmParallel | Kind::NmSequential => {
                let nm = NelderMead::new(&c.lower, &c.upper, &c.x0, nm_settings(n, matches!(c.kind, Kind::NmParallel))).unwrap();
                resume_matches(nm, split, 30)?;
            }
            Kind::De => {
                let de = DifferentialEvolution::new(&c.lower, &c.upper, Some(&c.x0), DeSettings { seed: c.seed, ..DeSettings::new(n) }).unwrap();
                resume_matches(de, split, 30)?;
            }
            Kind::Ga => {
                let ga = GeneticAlgorithm::new(&c.lower, &c.upper, Some(&c.x0), GaSettings { seed: c.seed, ..GaSettings::new(n) }).unwrap();
                resume_matches(ga, split, 30)?;
            }
        }
    }

    #[test]
    fn any_order_of_tells_gives_the_same_trajectory(c in case(), order in 1u64..u64::MAX) {
        let in_order = drive(build(&c).as_mut(), 30, 0);
        let shuffled = drive(build(&c).as_mut(), 30, order);
        prop_assert_eq!(in_order, shuffled);
    }

    #[test]
    fn failures_nan_and_infinities_never_panic(c in case(), pattern in prop::collection::vec(prop::sample::select(vec![0u8, 1, 2, 4]), 1..50)) {
        // Failures, NaN, +∞ and true values (no −∞: choice 3 is left out).
        let mut opt = build(&c);
        support::tell_by_pattern(
            opt.as_mut(),
            60,
            &pattern,
            |opt, cand, choice| opt.tell(cand.id, support::hostile_outcome(choice, &cand.x)).unwrap(),
            |_| Ok(()),
        )?;
        support::best_is_finite(opt.as_ref())?;
    }
}

#[test]
fn telling_an_unknown_or_repeated_id_is_an_error() {
    let mut nm = NelderMead::new(&[0.0], &[1.0], &[0.5], NmSettings::new(1)).unwrap();
    let batch = nm.ask();
    assert!(nm.tell(9999, Outcome::Value(1.0)).is_err());
    nm.tell(batch[0].id, Outcome::Value(1.0)).unwrap();
    assert!(nm.tell(batch[0].id, Outcome::Value(1.0)).is_err());
    assert_eq!(nm.ask().len(), batch.len() - 1, "asking again returns only the open candidates");
}
