//! Discrepancy discovery on models as tools export them: bases without injection
//! ports (`*Exported` fixtures, Dymola's FMI 2.0 description), so the diagnosis adds its
//! candidates to the continuous states' derivatives ("state effects") or to the outputs. No job
//! has a `[diagnose]` section: nothing to configure.
//!
//! The grid is hidden effects × noise 0.5, 1 and 2 % of each output's range × with and without
//! a driving input (spring-mass: no input mapped, the mass starts at x = 0.5 m and rings down,
//! or a sine force F mapped from the data; Furuta: no input, the pendulum starts at φ = 1 rad
//! and swings down, or a growing sine torque u; the exhaust pipe always has its five inputs), null
//! cases (data from the base itself), cases whose effect is outside fmucal's library (drifting
//! stiffness, periodic force, one-sided friction, growing mass) and a few effects at 10 % noise.
//! Every case is seeded. Hidden viscous damping is diagnosed on a base without a viscous term
//! of its own (the spring-mass with its damping d set to 0, only k calibrated), since on the
//! base with d calibrated it is that parameter.
//!
//! Besides the diagnosis's own held-out RMS (against the noisy data), each case measures the
//! gap against the noise-free truth: the RMS, over the held-out window, of the model's outputs
//! minus the noise-free outputs of the FMU the data came from. Before: the base model at the
//! diagnosis's base calibration (`rounds[0].base_x_opt`); after: the base model with the effect
//! named first (`rounds[0]`'s chosen candidate's effect) at that candidate's fitted values
//! (`fit.x_opt`). Both are simulated in this process through the job machinery
//! ([`PreparedJob::new`] and [`fmucal_shared::job::PreparedExperiment::sim_spec`], then
//! `apply_sensor_effects` for an effect on an output), on the whole record at tolerance 1e-10,
//! exactly as the data's noise-free simulation was. For a sensor offset the truth is the output
//! the fixture reports (position + offset), which is what the data measure.
//!
//! `cargo test --release --test diagnosis_exported` runs a subset; `bench/diagnose_exported.sh`
//! runs the whole grid (`full_grid`, ignored here) and prints the table and the targets.

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use common::diagnosis::{self, Inputs, Model, case_dir, fmucal};
use fmucal_diagnose::report::{Conclusion, Diagnosis};
use fmucal_models::Fixture;
use fmucal_shared::job::{JobSpec, MeasurementTable, PreparedJob};
use fmucal_shared::sim::{OutputTimes, SimResult, simulate};

/// What is hidden in the data.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Truth {
    /// Nothing: data from the base model.
    None(Model),
    Coulomb,
    Stribeck,
    Viscous,
    QuadraticDrag,
    Cubic,
    SensorOffset,
    PendulumCoulomb,
    Radiation,
    /// Outside fmucal's effect kinds.
    DriftingStiffness,
    PeriodicForce,
    OneSidedFriction,
    GrowingMass,
}

impl Truth {
    fn model(self) -> Model {
        match self {
            Truth::None(m) => m,
            Truth::PendulumCoulomb => Model::Furuta,
            Truth::Radiation => Model::Exhaust,
            _ => Model::SpringMass,
        }
    }

    /// The FMU the data come from.
    fn fmu(self) -> PathBuf {
        match self {
            Truth::None(m) => m.fmu(),
            Truth::Coulomb => Fixture::SpringMassExportedHiddenCoulomb.path(),
            Truth::Stribeck => Fixture::SpringMassExportedHiddenStribeck.path(),
            Truth::Viscous => Fixture::SpringMassExportedHiddenViscous.path(),
            Truth::QuadraticDrag => Fixture::SpringMassExportedHiddenQuadraticDrag.path(),
            Truth::Cubic => Fixture::SpringMassExportedHiddenCubic.path(),
            Truth::SensorOffset => Fixture::SpringMassExportedHiddenSensorOffset.path(),
            Truth::PendulumCoulomb => Fixture::FurutaExportedHiddenCoulomb.path(),
            Truth::Radiation => Fixture::ExhaustPipeExportedHiddenRadiation.path(),
            Truth::DriftingStiffness => Fixture::SpringMassExportedDriftingStiffness.path(),
            Truth::PeriodicForce => Fixture::SpringMassExportedPeriodicForce.path(),
            Truth::OneSidedFriction => Fixture::SpringMassExportedOneSidedFriction.path(),
            Truth::GrowingMass => Fixture::SpringMassExportedGrowingMass.path(),
        }
    }

    /// The candidate descriptions a right diagnosis names first: the true effect, then its
    /// family (Coulomb friction is Stribeck friction without the static peak; a joint friction
    /// has no Stribeck form with a reaction).
    fn expected(self) -> &'static [&'static str] {
        match self {
            Truth::Coulomb => &["coulomb_friction on der(mass.v)", "stribeck_friction on der(mass.v)"],
            Truth::Stribeck => &["stribeck_friction on der(mass.v)", "coulomb_friction on der(mass.v)"],
            Truth::Viscous => &["viscous_damping on der(mass.v)"],
            Truth::QuadraticDrag => &["quadratic_drag on der(mass.v)"],
            Truth::Cubic => &["cubic_spring of mass.x on der(mass.v)"],
            Truth::SensorOffset => &["sensor_offset on output mass.x"],
            // A joint torque: the term on the pendulum's acceleration and, through the mass
            // matrix, on the arm's.
            // A term on der(pendulumJoint.w) alone cannot express it, so only this one is right.
            Truth::PendulumCoulomb => &["coulomb_friction on der(pendulumJoint.w) and its reaction on der(armJoint.w)"],
            Truth::Radiation => &["radiation on der(rightVolume.wallT)"],
            _ => &[],
        }
    }

    fn kind(self) -> Kind {
        match self {
            Truth::None(_) => Kind::Null,
            Truth::DriftingStiffness | Truth::PeriodicForce | Truth::OneSidedFriction | Truth::GrowingMass => {
                Kind::Outside
            }
            _ => Kind::Effect,
        }
    }

    fn name(self) -> String {
        match self {
            Truth::None(m) => format!("none ({m:?})"),
            t => format!("{t:?}"),
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    /// A library effect the base cannot express: right is naming it (or its family) first.
    Effect,
    /// Data from the base itself: right is `fits`.
    Null,
    /// Outside the library: right is `misses_something`, nothing named.
    Outside,
}

impl Model {
    /// The base FMU, which the diagnosis uses.
    fn fmu(self) -> PathBuf {
        match self {
            Model::SpringMass => Fixture::SpringMassExported.path(),
            Model::Furuta => Fixture::FurutaExported.path(),
            Model::Exhaust => Fixture::ExhaustPipeExported.path(),
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct Case {
    truth: Truth,
    /// Noise standard deviation as a fraction of each output's range.
    noise: f64,
    /// Whether a driving input is mapped (the exhaust pipe always has its inputs).
    driven: bool,
    seed: u64,
}

/// Time grid and input columns of a model, driven or not.
fn inputs(model: Model, driven: bool) -> (Vec<f64>, Inputs) {
    match model {
        Model::SpringMass => diagnosis::exported_spring_mass_inputs(driven),
        // The free pendulum swings down from 1 rad within some 6 s (sooner with the hidden
        // Coulomb friction, which stops it): a 10 s record held out from 7.5 s. Driven: input
        // profile 1 of tests/diagnosis_grid.rs, which keeps the pendulum moving through the
        // held-out window, where a free swing has come to rest.
        Model::Furuta if driven => diagnosis::furuta_inputs(1),
        Model::Furuta => (diagnosis::time_grid(1000, 0.01), vec![]),
        Model::Exhaust => diagnosis::exhaust_inputs(),
    }
}

/// The job's `[[parameters]]`, `[simulation]` and `[optimizer]` tables; no `[diagnose]`.
fn job_body(truth: Truth) -> String {
    let tight = |parameters: &str, simulation: &str| format!("{parameters}{simulation}{}", diagnosis::TIGHT_OPTIMIZER);
    if truth == Truth::Viscous {
        // A base without a viscous term of its own: the spring-mass with its damping d set to
        // 0, only the stiffness calibrated; the data's mass is damped (d = 0.3 + 0.2).
        return tight(
            r#"[[parameters]]
name = "k"
start = 3.5
lower = 0.5
upper = 10.0
"#,
            "[simulation]\nstop_time = 15.0\nvalidation_stop_time = 20.0\ntolerance = 1e-8\nset = { d = 0.0 }\n",
        );
    }
    match truth.model() {
        Model::SpringMass => tight(Model::SpringMass.parameters(), diagnosis::SPRING_MASS_EXPORTED_SIMULATION),
        Model::Furuta => tight(Model::Furuta.parameters(), diagnosis::FURUTA_EXPORTED_SIMULATION),
        Model::Exhaust => format!("{}{}", Model::Exhaust.parameters(), diagnosis::EXHAUST_SETTINGS),
    }
}

/// Writes the case's noisy data and job into `dir`; returns the job file, the noise floor (the
/// RMS a perfect model has on the data) and the noise-free truth.
fn write_case(case: &Case, dir: &Path) -> (PathBuf, f64, SimResult) {
    let model = case.truth.model();
    let body = job_body(case.truth);
    let data = inputs(model, case.driven);
    diagnosis::write_case(dir, &case.truth.fmu(), &model.fmu(), model, data, case.noise, case.seed, &body)
}

/// A case's diagnosis, the noise floor of its data and the gap against the truth.
struct Outcome {
    report: Diagnosis,
    /// The RMS a perfect model has on the data (the noise), to compare the gap with.
    floor: f64,
    /// RMS of model − noise-free truth on the held-out window: the base model at its
    /// calibrated values, and the model with the effect named first at its fitted values.
    gap_before: f64,
    gap_after: Option<f64>,
}

impl Outcome {
    fn gap_shrink(&self) -> Option<f64> {
        self.gap_after.map(|a| 1.0 - a / self.gap_before)
    }
}

/// What the diagnosis named first, in the words of a candidate description (none where the
/// chosen candidate left the model far from its noise and was reported as partial).
fn named(d: &Diagnosis) -> Option<String> {
    let round = d.rounds.first()?;
    round.chosen.filter(|_| !d.named.is_empty()).map(|k| round.candidates[k].description.clone())
}

/// RMS over the held-out window (calibration_stop, validation_stop] of the simulated outputs of
/// `job` (with `extra` effects) at the values `x_opt` minus `truth`, over the outputs.
fn gap(
    job: &Path,
    extra: &[fmucal_shared::job::spec::EffectSpec],
    x_opt: &BTreeMap<String, f64>,
    d: &Diagnosis,
    truth: &SimResult,
    dir: &Path,
) -> f64 {
    let mut spec = JobSpec::from_toml_file(job).unwrap();
    spec.effects.extend(extra.iter().cloned());
    let data = MeasurementTable::read(&job.parent().unwrap().join("data.csv"), "time").unwrap();
    let fmu = common::load(spec.model.path.as_ref().expect("a model path"), &dir.join("cache"));
    let prepared = PreparedJob::new(&spec, &fmu.description, &fmu.interfaces(), std::slice::from_ref(&data)).unwrap();
    let x: Vec<f64> = prepared
        .parameter_names
        .iter()
        .map(|n| *x_opt.get(n).unwrap_or_else(|| panic!("{n} not among the fitted values {x_opt:?}")))
        .collect();
    let e = prepared.single();
    let mut sim = e.sim_spec(&x);
    let w = &d.windows;
    sim.start_time = Some(truth.time[0]);
    sim.stop_time = Some(w.validation_stop);
    sim.output_times =
        Some(OutputTimes::Times(truth.time.iter().copied().filter(|t| *t <= w.validation_stop).collect()));
    sim.outputs = truth.names.clone();
    sim.tolerance = Some(1e-10);
    let mut result = simulate(&fmu, &sim).unwrap();
    e.apply_sensor_effects(&x, &mut result);
    let mut sum = 0.0;
    for (k, name) in truth.names.iter().enumerate() {
        let model = result.column(name).unwrap();
        let (mut s, mut n) = (0.0, 0);
        for (i, t) in truth.time.iter().enumerate() {
            if *t > w.calibration_stop && *t <= w.validation_stop {
                s += (model[i] - truth.columns[k][i]).powi(2);
                n += 1;
            }
        }
        sum += s / n as f64;
    }
    (sum / truth.names.len() as f64).sqrt()
}

/// Runs `fmucal diagnose --workers 2` on the case and measures the gap against the truth.
fn diagnose(case: &Case, dir: &Path) -> Outcome {
    let (job, floor, truth) = write_case(case, dir);
    let report = diagnosis::diagnose(case, &job, dir);
    let round = report.rounds.first().expect("a round");
    let gap_before = gap(&job, &[], &round.base_x_opt, &report, &truth, dir);
    let gap_after = round.chosen.filter(|_| !report.named.is_empty()).map(|k| {
        let c = &round.candidates[k];
        let fit = c.fit.as_ref().expect("the named candidate was fitted");
        gap(&job, std::slice::from_ref(&c.candidate.effect), &fit.x_opt, &report, &truth, dir)
    });
    eprintln!(
        "gap against the noise-free truth on the held-out window: {gap_before:.3e} → {}",
        gap_after.map_or("—".to_owned(), |g| format!("{g:.3e}"))
    );
    Outcome { report, floor, gap_before, gap_after }
}

/// A case whose data hide a library effect: the true effect is named first, the conclusion is
/// `named`, and the gap against the noise-free truth on the held-out window at least halves.
fn named_and_gap_shrinks(truth: Truth, noise: f64, driven: bool, seed: u64, name: &str) {
    let (_keep, dir) = case_dir(name);
    let o = diagnose(&Case { truth, noise, driven, seed }, &dir);
    let d = &o.report;
    assert_eq!(named(d).as_deref(), Some(truth.expected()[0]), "{}", d.summary());
    assert_eq!(d.conclusion, Conclusion::Named, "{}", d.summary());
    let after = o.gap_after.expect("named");
    assert!(after <= 0.5 * o.gap_before, "gap against the truth {:.3e} → {after:.3e}: {}", o.gap_before, d.summary());
}

/// A case whose data hide nothing the library has: `conclusion` as given, nothing named.
fn concludes(truth: Truth, noise: f64, driven: bool, seed: u64, name: &str, conclusion: Conclusion) {
    let (_keep, dir) = case_dir(name);
    let d = diagnose(&Case { truth, noise, driven, seed }, &dir).report;
    assert_eq!(named(&d), None, "{}", d.summary());
    assert_eq!(d.conclusion, conclusion, "{}", d.summary());
    // `fmucal calibrate` on the same job warns exactly when the model misses something: the
    // same test of "far from the noise".
    let run = fmucal("calibrate", &dir.join("job.toml"), &dir.join("calibration"));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    let warned = stderr.contains("warning: the fit leaves more than noise (");
    assert_eq!(warned, conclusion == Conclusion::MissesSomething, "{stderr}");
}

#[test]
fn a_coulomb_friction_in_a_ring_down_is_named_on_der_v() {
    named_and_gap_shrinks(Truth::Coulomb, 0.01, false, 1, "coulomb-free");
}

#[test]
fn a_coulomb_friction_under_a_driving_force_is_named_on_der_v() {
    named_and_gap_shrinks(Truth::Coulomb, 0.01, true, 2, "coulomb-driven");
}

#[test]
fn a_pendulum_joint_friction_under_a_driving_torque_is_named_with_its_reaction_on_the_arm() {
    // The grid's case 37: the joint torque reaches both accelerations, which only the candidate
    // with a reaction on the coupled arm velocity expresses.
    named_and_gap_shrinks(Truth::PendulumCoulomb, 0.005, true, 2738, "pendulum-coulomb-driven");
}

#[test]
fn a_viscous_damping_missing_from_a_base_without_one_is_named_on_der_v() {
    named_and_gap_shrinks(Truth::Viscous, 0.01, false, 2715, "viscous");
}

#[test]
fn a_cubic_spring_is_named_as_a_spring_of_the_position_on_der_v() {
    named_and_gap_shrinks(Truth::Cubic, 0.01, false, 3, "cubic");
}

#[test]
fn a_radiating_exhaust_wall_is_found_on_a_wall_but_one_output_cannot_say_which() {
    // Only outlet.T is measured: a heat loss of the left wall and one of the right wall move it
    // alike, so the best candidates on both walls are equally supported and none is named.
    let (_keep, dir) = case_dir("radiation");
    let d = diagnose(&Case { truth: Truth::Radiation, noise: 0.01, driven: true, seed: 4 }, &dir).report;
    assert_eq!((named(&d), d.conclusion), (None, Conclusion::MissesSomething), "{}", d.summary());
    assert!(d.summary().contains("the data do not say where the model is wrong"), "{}", d.summary());
    // The best fitted candidates are heat losses of the two walls, and they pass every test.
    let round = &d.rounds[0];
    let best: Vec<&str> = round.candidates[..2].iter().map(|c| c.description.as_str()).collect();
    assert!(
        best.iter().all(|b| b.contains("der(leftVolume.wallT)") || b.contains("der(rightVolume.wallT)")),
        "{best:?}"
    );
    assert!(round.candidates.iter().any(|c| c.description == "radiation on der(rightVolume.wallT)"
        && c.fit.as_ref().and_then(|f| f.verdict.as_ref()).is_some_and(|v| v.accepted())));
}

#[test]
fn a_sensor_offset_is_named_on_the_output() {
    named_and_gap_shrinks(Truth::SensorOffset, 0.01, false, 7, "offset");
}

#[test]
fn data_from_the_exported_base_itself_fit() {
    concludes(Truth::None(Model::SpringMass), 0.01, false, 5, "null", Conclusion::Fits);
}

#[test]
fn a_drifting_stiffness_is_something_the_model_misses() {
    concludes(Truth::DriftingStiffness, 0.01, false, 6, "drift", Conclusion::MissesSomething);
}

/// Every case of the grid.
fn grid() -> Vec<Case> {
    let mut cases = vec![];
    let mut seed = 2700;
    let mut push = |truth: Truth, noise: f64, driven: bool| {
        seed += 1;
        cases.push(Case { truth, noise, driven, seed });
    };
    let spring_effects =
        [Truth::Coulomb, Truth::Stribeck, Truth::Viscous, Truth::QuadraticDrag, Truth::Cubic, Truth::SensorOffset];
    for truth in spring_effects.into_iter().chain([Truth::PendulumCoulomb]) {
        for noise in [0.005, 0.01, 0.02] {
            for driven in [false, true] {
                push(truth, noise, driven);
            }
        }
    }
    for noise in [0.005, 0.01, 0.02] {
        push(Truth::Radiation, noise, true);
    }
    for noise in [0.005, 0.01, 0.02] {
        for driven in [false, true] {
            push(Truth::None(Model::SpringMass), noise, driven);
        }
    }
    push(Truth::None(Model::Furuta), 0.01, false);
    push(Truth::None(Model::Furuta), 0.02, true);
    push(Truth::None(Model::Exhaust), 0.01, true);
    push(Truth::None(Model::Exhaust), 0.02, true);
    for (k, truth) in [Truth::DriftingStiffness, Truth::PeriodicForce, Truth::OneSidedFriction, Truth::GrowingMass]
        .into_iter()
        .enumerate()
    {
        push(truth, 0.01, k % 2 == 1);
        push(truth, 0.02, k % 2 == 0);
    }
    for truth in [Truth::Coulomb, Truth::Cubic, Truth::QuadraticDrag, Truth::SensorOffset, Truth::PendulumCoulomb] {
        push(truth, 0.1, false);
    }
    push(Truth::Radiation, 0.1, true);
    cases
}

fn conclusion_word(c: Conclusion) -> &'static str {
    match c {
        Conclusion::Named => "named",
        Conclusion::MissesSomething => "misses_something",
        Conclusion::Fits => "fits",
    }
}

/// The whole grid, as `bench/diagnose_exported.sh` runs it: one table row per case, then the
/// targets it is held to.
#[test]
#[ignore = "the full grid takes long; run bench/diagnose_exported.sh"]
fn full_grid() {
    diagnosis::print_table_head(&[
        "case",
        "truth",
        "noise",
        "driven",
        "conclusion",
        "named first",
        "right",
        "validation RMS before → after",
        "gap to truth before → after",
        "gap before ÷ noise",
        "gap shrink",
        "time [s]",
    ]);
    let (mut effect_right, mut effect_total, mut effect_tied) = (0, 0, 0);
    let (mut null_fits, mut null_total, mut null_misses) = (0, 0, 0);
    let (mut outside_right, mut outside_total, mut outside_wrong) = (0, 0, 0);
    let (mut loud_wrong, mut loud_total) = (0, 0);
    // Gap halved: over every case where something was named, and over the library-effect cases.
    let (mut gap_halved, mut gap_cases, mut effect_gap_halved, mut effect_gap_cases) = (0, 0, 0, 0);
    let mut misses: Vec<String> = vec![];
    for (k, case) in diagnosis::selected(grid()) {
        let (_keep, dir) = case_dir(&format!("case{k:02}"));
        let o = diagnose(&case, &dir);
        let d = &o.report;
        let got = named(d);
        let expected = case.truth.expected();
        let kind = case.truth.kind();
        let loud = case.noise > 0.05;
        let wrong_name = got.as_deref().is_some_and(|g| !expected.contains(&g));
        let right = match kind {
            // At 10 % noise abstaining is right too; naming a wrong effect is not.
            Kind::Effect if loud => !wrong_name,
            Kind::Effect => got.as_deref().is_some_and(|g| expected.contains(&g)),
            Kind::Null => d.conclusion == Conclusion::Fits,
            Kind::Outside => d.conclusion == Conclusion::MissesSomething && got.is_none(),
        };
        let family = right && kind == Kind::Effect && got.is_some() && got.as_deref() != Some(expected[0]);
        // The true effect among those the data support as well as the one named, or among the
        // candidates at different places that tie, so that none is named.
        let tied = !right
            && kind == Kind::Effect
            && d.rounds.first().is_some_and(|r| {
                r.equally_supported
                    .iter()
                    .chain(&r.elsewhere())
                    .any(|i| expected.contains(&r.candidates[*i].description.as_str()))
            });
        if loud {
            loud_total += 1;
            loud_wrong += usize::from(wrong_name);
        } else {
            match kind {
                Kind::Effect => {
                    effect_total += 1;
                    effect_right += usize::from(right);
                    effect_tied += usize::from(tied);
                }
                Kind::Null => {
                    null_total += 1;
                    null_fits += usize::from(right);
                    null_misses += usize::from(d.conclusion == Conclusion::MissesSomething);
                }
                Kind::Outside => {
                    outside_total += 1;
                    outside_right += usize::from(right);
                    outside_wrong += usize::from(got.is_some());
                }
            }
        }
        let shrink = o.gap_shrink();
        if let Some(s) = shrink {
            gap_cases += 1;
            gap_halved += usize::from(s >= 0.5);
            if kind == Kind::Effect {
                effect_gap_cases += 1;
                effect_gap_halved += usize::from(s >= 0.5);
            }
            if s < 0.5 {
                misses.push(format!("case {k}: the gap to the truth shrank by only {:.0} %", 100.0 * s));
            }
        }
        if !right {
            misses.push(format!(
                "case {k} ({}, {} % noise, {}): {}",
                case.truth.name(),
                100.0 * case.noise,
                if case.driven { "driven" } else { "not driven" },
                d.summary().trim_end().replace('\n', "\n    ")
            ));
        }
        println!(
            "| {k} | {} | {} % | {} | {} | {} | {} | {:.3e} → {:.3e} | {:.3e} → {} | {:.2} | {} | {:.1} |",
            case.truth.name(),
            100.0 * case.noise,
            if case.driven { "yes" } else { "no" },
            conclusion_word(d.conclusion),
            got.as_deref().unwrap_or("—"),
            if family {
                "family"
            } else if right && loud && got.is_none() {
                "abstained"
            } else if right {
                "yes"
            } else if tied {
                "tied"
            } else {
                "NO"
            },
            d.before.validation,
            d.after.validation,
            o.gap_before,
            o.gap_after.map_or("—".to_owned(), |g| format!("{g:.3e}")),
            o.gap_before / o.floor,
            shrink.map_or("—".to_owned(), |s| format!("{:.0} %", 100.0 * s)),
            d.elapsed_s,
        );
    }
    println!();
    let pct = |a: usize, b: usize| if b == 0 { 0.0 } else { 100.0 * a as f64 / b as f64 };
    println!(
        "target: true effect (or its family) named first at ≤ 2 % noise: {effect_right}/{effect_total} ({:.0} %, target ≥ 90 %)",
        pct(effect_right, effect_total)
    );
    println!("target:   (and {effect_tied} more where the true effect is among the equally supported)");
    println!(
        "target: null cases concluding fits: {null_fits}/{null_total} ({:.0} %, target ≥ 95 %); null cases concluding misses_something: {null_misses} (target 0)",
        pct(null_fits, null_total)
    );
    println!(
        "target: outside-library cases concluding misses_something without a name: {outside_right}/{outside_total} ({:.0} %, target ≥ 90 %); a (wrong) name: {outside_wrong}",
        pct(outside_right, outside_total)
    );
    println!("target: at 10 % noise, a wrong effect named: {loud_wrong}/{loud_total} (target 0)");
    println!(
        "target: gap against the noise-free truth on the held-out window at least halved where an effect was named: {gap_halved}/{gap_cases} ({:.0} %, target ≥ 90 %); on the library-effect cases: {effect_gap_halved}/{effect_gap_cases} ({:.0} %)",
        pct(gap_halved, gap_cases),
        pct(effect_gap_halved, effect_gap_cases)
    );
    for m in misses {
        println!("miss: {m}");
    }
}
