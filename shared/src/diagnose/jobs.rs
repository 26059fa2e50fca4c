//! The jobs a diagnosis builds from the base job: a candidate's calibration (the base with the
//! candidate added, starting where the screening points) and the base of a next round (the job
//! with every start at the fitted values). Pure; the driver submits them.

use std::collections::BTreeMap;

use super::candidates::Candidate;
use crate::job::spec::{EffectSpec, JobSpec, SetValue};

/// `job` with the start of every calibrated value named in `values` (`[[parameters]]` by name,
/// effect parameters as `effects[K].NAME`) set to that value, clamped into its bounds.
pub fn with_starts(mut job: JobSpec, values: &BTreeMap<String, f64>) -> JobSpec {
    for p in &mut job.parameters {
        if let Some(v) = values.get(&p.name).filter(|v| v.is_finite()) {
            p.start = v.clamp(p.lower, p.upper);
        }
    }
    for (k, e) in job.effects.iter_mut().enumerate() {
        for (name, b) in e.parameters.iter_mut() {
            if let Some(v) = values.get(&format!("effects[{k}].{name}")).filter(|v| v.is_finite()) {
                b.start = v.clamp(b.lower, b.upper);
            }
        }
    }
    job
}

/// The calibration of `candidate` added to `base`: the base's values start at `starts`, the
/// candidate's parameters at `effect_starts`; with `fix_base`, the base's `[[parameters]]` are
/// fixed at their starts (`[simulation] set`) and only the effects are fitted.
pub fn candidate_job(
    base: &JobSpec,
    starts: &BTreeMap<String, f64>,
    candidate: &Candidate,
    effect_starts: &[f64],
    fix_base: bool,
) -> JobSpec {
    let mut job = with_starts(base.clone(), starts);
    job.diagnose = None;
    if fix_base {
        for p in std::mem::take(&mut job.parameters) {
            job.simulation.set.insert(p.name.clone(), SetValue::Number(p.start));
        }
    }
    job.effects.push(candidate.with_starts(effect_starts));
    job
}

/// Two effects of the same kind acting at the same place.
pub fn same_place(a: &EffectSpec, b: &EffectSpec) -> bool {
    a.kind == b.kind && a.port == b.port && a.signal == b.signal && a.output == b.output && a.input == b.input
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::diagnose::guess::Guess;

    fn base() -> JobSpec {
        let text = r#"
[model]
path = "m.fmu"
[data]
path = "d.csv"
[[outputs]]
variable = "y"
column = "y"
[[parameters]]
name = "k"
start = 1.0
lower = 0.0
upper = 2.0
[[effects]]
kind = "sensor_offset"
output = "y"
parameters = { offset = { start = 0.0, lower = -1.0, upper = 1.0 } }
[diagnose]
top = 3
"#;
        JobSpec::from_toml(text, Path::new("/")).unwrap()
    }

    fn coulomb() -> Candidate {
        let mut effect = EffectSpec {
            kind: "coulomb_friction".into(),
            port: Some("p".into()),
            signal: Some("v".into()),
            output: None,
            input: None,
            parameters: Default::default(),
        };
        effect.parameters.insert("force".into(), crate::job::spec::Bounds { start: 0.0, lower: 0.0, upper: 0.1 });
        Candidate {
            effect,
            guesses: vec![Guess { neutral: 0.0, step: Some(0.01), lower: 0.0, upper: 0.1 }],
            source: "diagnose.ports[0].velocities[0]".into(),
        }
    }

    #[test]
    fn a_candidate_job_starts_where_it_is_told_and_clamps_into_the_bounds() {
        let starts: BTreeMap<String, f64> = [("k".into(), 1.5), ("effects[0].offset".into(), 7.0)].into();
        let job = candidate_job(&base(), &starts, &coulomb(), &[0.03], false);
        assert_eq!(job.parameters[0].start, 1.5);
        assert_eq!(job.effects[0].parameters["offset"].start, 1.0, "clamped to the upper bound");
        assert_eq!(job.effects[1].kind, "coulomb_friction");
        assert_eq!(job.effects[1].parameters["force"].start, 0.03);
        assert_eq!(job.diagnose, None);
        job.validate().unwrap();
        let (names, ..) = job.parameter_vectors();
        assert_eq!(names, ["k", "effects[0].offset", "effects[1].force"]);
    }

    #[test]
    fn with_fix_base_the_base_parameters_are_set_and_only_effects_are_fitted() {
        let starts: BTreeMap<String, f64> = [("k".into(), 1.25)].into();
        let job = candidate_job(&base(), &starts, &coulomb(), &[0.03], true);
        assert!(job.parameters.is_empty());
        assert_eq!(job.simulation.set["k"], SetValue::Number(1.25));
        let (names, ..) = job.parameter_vectors();
        assert_eq!(names, ["effects[0].offset", "effects[1].force"]);
    }

    #[test]
    fn the_same_kind_at_the_same_place_is_the_same_effect() {
        let a = coulomb().effect;
        let mut b = a.clone();
        b.parameters.clear();
        assert!(same_place(&a, &b));
        b.signal = Some("w".into());
        assert!(!same_place(&a, &b));
    }
}
