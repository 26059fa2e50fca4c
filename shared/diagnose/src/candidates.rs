//! Candidate generation and screening (steps 3 of a diagnosis).
//!
//! [`generate`] lists every effect kind at every place it fits ([`super::places`]): each
//! compatible (port, signal) pair, each state's derivative (with the state or its position as
//! signal), sensor effects on every output and actuator effects on every input, each with its
//! parameters guessed from the sizes of this job ([`fmucal_shared::effects::guess`]): a port's load scale, a
//! state's derivative scale.
//!
//! [`Screening`] ranks them without fitting any: all candidates are added to one job at their
//! neutral values (where each does nothing), and one batch of points measures the residual's
//! sensitivity to every base parameter and every candidate's strength parameters by forward
//! differences. For each candidate the Gauss–Newton model of the residual r ≈ r₀ + J_b·δ_b +
//! J_e·δ_e predicts the drop D in the sum of squares that adding it allows (beyond what the
//! base parameters already do), which is the score (Lagrange multiplier) statistic
//! LM = n_eff·D/SSR (q strength parameters, q degrees of freedom); candidates are ranked by the
//! predicted change of the information criterion, n_eff·ln((SSR − D)/SSR) + p·ln(n_eff) with p
//! all the candidate's parameters (as the decision counts them), so a candidate with more
//! parameters must explain more.

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use super::places::Places;
use super::spec::{DiagnoseSpec, PortDomain};
use fmucal_shared::effects::guess::{self, Guess, Guesses, Scales, SignalRole, SignalStats};
use fmucal_shared::effects::{self, Domain, Found};
use fmucal_shared::job::identifiability::relative_step;
use fmucal_shared::job::spec::{Bounds, EffectSpec, JobSpec};
use fmucal_shared::residuals::chi_squared_survival;
use fmucal_shared::structure::Role;

/// One candidate effect.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    /// The `[[effects]]` entry it would add, its starts at the neutral values.
    pub effect: EffectSpec,
    /// One guess per parameter, in the kind's order.
    pub guesses: Vec<Guess>,
    /// The job field it comes from (`diagnose.ports[0].velocities[1]`, `outputs[1]`, ...).
    pub source: String,
}

impl Candidate {
    /// The candidate in words: "coulomb_friction on pendulumJoint.w through pendulumJoint.tauExt".
    pub fn describe(&self) -> String {
        let e = &self.effect;
        match (&e.port, &e.signal, &e.output, &e.input) {
            _ if e.state.is_some() => {
                let state = e.state.as_deref().unwrap_or_default();
                let words = match e.signal.as_deref() {
                    Some(s) if s != state => format!("{} of {s} on der({state})", e.kind),
                    _ => format!("{} on der({state})", e.kind),
                };
                match &e.reaction {
                    Some(r) => format!("{words} and its reaction on der({r})"),
                    None => words,
                }
            }
            (Some(p), Some(s), _, _) => format!("{} on {s} through {p}", e.kind),
            (_, _, Some(o), _) => format!("{} on output {o}", e.kind),
            (_, _, _, Some(i)) => format!("{} on input {i}", e.kind),
            _ => e.kind.clone(),
        }
    }

    /// Where it acts, in words: `der(mass.v)`, `port mass.Fext`, `output mass.x`, `input u`.
    pub fn place(&self) -> String {
        super::decision::place(&self.effect)
    }

    /// The effect's parameter names, in order ([`EffectSpec::parameter_names`]).
    pub fn parameter_names(&self) -> Vec<&'static str> {
        self.effect.parameter_names()
    }

    /// The candidate with each strength parameter's bounds narrowed around `estimate`: within
    /// max(4·|estimate − neutral|, 20·|step|) of the neutral value (and the guessed bounds), so
    /// the optimizer's steps, a fraction of the range, suit the effect's size.
    pub fn narrowed(&self, estimate: &[f64]) -> Candidate {
        let mut c = self.clone();
        for (g, e) in c.guesses.iter_mut().zip(estimate) {
            if let Some(h) = g.step {
                let d = if e.is_finite() { (e - g.neutral).abs() } else { 0.0 };
                let half = (4.0 * d).max(20.0 * h.abs());
                (g.lower, g.upper) = (g.lower.max(g.neutral - half), g.upper.min(g.neutral + half));
            }
        }
        let starts: Vec<f64> = c.guesses.iter().map(|g| g.neutral).collect();
        c.effect = c.with_starts(&starts);
        c
    }

    /// The effect entry with the given starts (clipped into the bounds).
    pub fn with_starts(&self, starts: &[f64]) -> EffectSpec {
        let mut e = self.effect.clone();
        for ((name, g), s) in self.parameter_names().iter().zip(&self.guesses).zip(starts) {
            let start = if s.is_finite() { s.clamp(g.lower, g.upper) } else { g.neutral };
            e.parameters.insert((*name).to_owned(), Bounds { start, lower: g.lower, upper: g.upper });
        }
        e
    }
}

/// What the guesses are made from.
#[derive(Debug, Clone, Default)]
pub struct Sizes {
    /// Load scale of each port.
    pub port_scales: BTreeMap<String, f64>,
    /// Derivative scale of each state: the constant rate added to its derivative that moves
    /// the outputs about as much as the residual is large.
    pub state_scales: BTreeMap<String, f64>,
    /// Simulated signals of the ports on the calibration window.
    pub signals: BTreeMap<String, SignalStats>,
    /// Measured outputs and inputs (by FMU variable) on the calibration window.
    pub series: BTreeMap<String, SignalStats>,
    pub duration: f64,
    pub sample: f64,
}

fn effect(
    kind: &str,
    port: Option<&str>,
    signal: Option<&str>,
    output: Option<&str>,
    input: Option<&str>,
) -> EffectSpec {
    EffectSpec {
        kind: kind.to_owned(),
        state: None,
        reaction: None,
        port: port.map(str::to_owned),
        signal: signal.map(str::to_owned),
        output: output.map(str::to_owned),
        input: input.map(str::to_owned),
        parameters: BTreeMap::new(),
    }
}

fn candidate(mut e: EffectSpec, kind: &dyn Guesses, scales: &Scales, source: String) -> Candidate {
    let guesses = kind.guesses(scales);
    let names = effects::find(&e.kind).map(|f| f.kind().parameters()).unwrap_or_default();
    for (name, g) in names.iter().zip(&guesses) {
        e.parameters.insert((*name).to_owned(), Bounds { start: g.neutral, lower: g.lower, upper: g.upper });
    }
    Candidate { effect: e, guesses, source }
}

/// Every candidate the job allows: port effects on each port of `places` (in its order), state
/// effects on each state (Model Exchange), then sensor effects on each output and actuator
/// effects on each input. A signal or series without statistics in `sizes` is left out.
pub fn generate(job: &JobSpec, diagnose: &DiagnoseSpec, places: &Places, sizes: &Sizes) -> Vec<Candidate> {
    let mut out = vec![];
    for place in &places.ports {
        let port = &place.spec;
        let domain = match port.domain {
            PortDomain::Mechanical => Domain::Mechanical,
            PortDomain::Thermal => Domain::Thermal,
        };
        // A port the probe could not size gets no candidates (the probe says why).
        let Some(&load) = sizes.port_scales.get(&port.port) else { continue };
        let ambient = port.ambient.unwrap_or(293.15);
        for kind in effects::port_kinds().iter().filter(|e| e.domain() == domain) {
            let signals: Vec<(String, &str)> = match kind.signal_role() {
                SignalRole::Velocity => {
                    port.velocities.iter().enumerate().map(|(i, s)| (format!("velocities[{i}]"), s.as_str())).collect()
                }
                SignalRole::Position => {
                    port.positions.iter().enumerate().map(|(i, s)| (format!("positions[{i}]"), s.as_str())).collect()
                }
                SignalRole::Temperature => port
                    .temperatures
                    .iter()
                    .enumerate()
                    .map(|(i, s)| (format!("temperatures[{i}]"), s.as_str()))
                    .collect(),
                SignalRole::Any => port.signals().take(1).collect(),
                SignalRole::Series | SignalRole::State => vec![],
            };
            for (field, signal) in signals {
                let Some(stats) = sizes.signals.get(signal) else { continue };
                let scales = Scales { load, signal: *stats, duration: sizes.duration, sample: sizes.sample, ambient };
                let e = effect(kind.name(), Some(&port.port), Some(signal), None, None);
                let source = if place.by_hand { format!("{}.{field}", place.source) } else { place.source.clone() };
                out.push(candidate(e, *kind, &scales, source));
            }
        }
    }
    for place in &places.states {
        let Some(&load) = sizes.state_scales.get(&place.state) else { continue };
        let domain = match place.role {
            Role::Velocity => Domain::Mechanical,
            Role::Temperature => Domain::Thermal,
            Role::Other => Domain::Generic,
            Role::Position => continue,
        };
        for kind in effects::port_kinds().iter().filter(|e| e.domain() == domain) {
            let signal = match kind.signal_role() {
                SignalRole::Position => match &place.position {
                    Some(p) => p.as_str(),
                    None => continue,
                },
                _ => place.state.as_str(),
            };
            let Some(stats) = sizes.signals.get(signal) else { continue };
            let scales =
                Scales { load, signal: *stats, duration: sizes.duration, sample: sizes.sample, ambient: 293.15 };
            let mut e = effect(kind.name(), None, Some(signal), None, None);
            e.state = Some(place.state.clone());
            let source = format!("model state {}", place.state);
            out.push(candidate(e.clone(), *kind, &scales, source.clone()));
            // Friction, damping and drag of a coupled joint: the same term on each coupled
            // velocity's derivative too, at a strength of its own (the mass matrix's share).
            if kind.signal_role() == SignalRole::Velocity && kind.proportional() {
                for coupled in &place.coupled {
                    let Some(&load) = sizes.state_scales.get(coupled) else { continue };
                    let mut e = e.clone();
                    e.reaction = Some(coupled.clone());
                    let mut c = candidate(e, *kind, &scales, source.clone());
                    let g = guess::reaction(*kind, &Scales { load, ..scales });
                    let bounds = Bounds { start: g.neutral, lower: g.lower, upper: g.upper };
                    c.effect.parameters.insert(effects::REACTION.to_owned(), bounds);
                    c.guesses.push(g);
                    out.push(c);
                }
            }
        }
    }
    if diagnose.series {
        let series: Vec<(Domain, String, &str)> = job
            .outputs
            .iter()
            .enumerate()
            .map(|(k, o)| (Domain::Sensor, format!("outputs[{k}]"), o.variable.as_str()))
            .chain(
                job.inputs
                    .iter()
                    .enumerate()
                    .map(|(k, i)| (Domain::Actuator, format!("inputs[{k}]"), i.variable.as_str())),
            )
            .collect();
        for (domain, source, variable) in series {
            if diagnose.exclude.iter().any(|e| e == variable) {
                continue;
            }
            let Some(stats) = sizes.series.get(variable) else { continue };
            let scales = Scales {
                load: stats.range(),
                signal: *stats,
                duration: sizes.duration,
                sample: sizes.sample,
                ambient: 0.0,
            };
            for kind in effects::series_kinds().iter().filter(|e| e.domain() == domain) {
                let e = match domain {
                    Domain::Sensor => effect(kind.name(), None, None, Some(variable), None),
                    _ => effect(kind.name(), None, None, None, Some(variable)),
                };
                out.push(candidate(e, *kind, &scales, source.clone()));
            }
        }
    }
    out
}

/// The screening of a set of candidates against a calibrated base job.
#[derive(Debug, Clone)]
pub struct Screening {
    /// The base job with every candidate added at its neutral values.
    pub job: JobSpec,
    /// The points to evaluate (residuals wanted): the base optimum with all candidates neutral,
    /// then one forward step per base parameter, then one per candidate strength parameter.
    pub points: Vec<Vec<f64>>,
    /// Base parameters' steps (empty when the base is held fixed).
    base_steps: Vec<(usize, f64)>,
    /// Per candidate, where its parameters sit in a point and its strength steps (index, step).
    strengths: Vec<(std::ops::Range<usize>, Vec<(usize, f64)>)>,
    /// Bounds of every parameter of `job`.
    lower: Vec<f64>,
    upper: Vec<f64>,
}

/// One candidate's screening statistics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Screened {
    /// Predicted drop of the sum of squares.
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub predicted_drop: f64,
    /// Score statistic n_eff·D/SSR and its p-value (χ² with q degrees of freedom).
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub score: f64,
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub p_value: f64,
    /// Predicted change of the information criterion (negative: better).
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub predicted_delta_ic: f64,
    /// The Gauss–Newton estimate of each parameter (shape parameters at their guess).
    #[serde(with = "fmucal_shared::optim::serde_float::vec")]
    pub estimate: Vec<f64>,
    /// The same Gauss–Newton step's change of each base parameter (0 for one held fixed).
    #[serde(with = "fmucal_shared::optim::serde_float::vec")]
    pub base_step: Vec<f64>,
}

impl Screening {
    /// Sets up the screening of `candidates` around the base optimum `x_base` of `base` (in
    /// its parameter order). `fix_base`: the base parameters are not varied.
    pub fn new(base: &JobSpec, x_base: &[f64], candidates: &[Candidate], fix_base: bool) -> Screening {
        let mut job = base.clone();
        job.diagnose = None;
        let (_, _, lower, upper) = base.parameter_vectors();
        let mut x0 = x_base.to_vec();
        let mut strengths = vec![];
        for c in candidates {
            job.effects.push(c.effect.clone());
            let offset = x0.len();
            let steps =
                c.guesses.iter().enumerate().filter_map(|(j, g)| g.step.map(|h| (offset + j, h))).collect::<Vec<_>>();
            x0.extend(c.guesses.iter().map(|g| g.neutral));
            strengths.push((offset..x0.len(), steps));
        }
        let base_steps: Vec<(usize, f64)> = if fix_base {
            vec![]
        } else {
            (0..x_base.len())
                .map(|i| {
                    let h = relative_step(x_base[i], lower[i], upper[i]);
                    // Forward, else backward, else as far as the bounds allow.
                    let h = if x_base[i] + h <= upper[i] {
                        h
                    } else if x_base[i] - h >= lower[i] {
                        -h
                    } else if upper[i] - x_base[i] >= x_base[i] - lower[i] {
                        upper[i] - x_base[i]
                    } else {
                        lower[i] - x_base[i]
                    };
                    (i, h)
                })
                .filter(|(_, h)| *h != 0.0)
                .collect()
        };
        let mut points = vec![x0.clone()];
        for &(i, h) in base_steps.iter().chain(strengths.iter().flat_map(|(_, s)| s)) {
            let mut p = x0.clone();
            p[i] += h;
            points.push(p);
        }
        let (_, _, lower, upper) = job.parameter_vectors();
        Screening { job, points, base_steps, strengths, lower, upper }
    }

    /// The statistics of every candidate (in the order given to [`Screening::new`]) from the
    /// residual vectors of [`Screening::points`] (`None`: the point's simulation failed, which
    /// makes its candidate's statistics NaN) and the effective sample size `n_eff`.
    pub fn statistics(&self, residuals: &[Option<Vec<f64>>], n_eff: f64) -> Vec<Screened> {
        let failed = || Screened {
            predicted_drop: f64::NAN,
            score: f64::NAN,
            p_value: f64::NAN,
            predicted_delta_ic: f64::NAN,
            estimate: vec![],
            base_step: vec![],
        };
        let Some(Some(r0)) = residuals.first() else {
            return self.strengths.iter().map(|_| failed()).collect();
        };
        let m = r0.len();
        let ssr: f64 = r0.iter().map(|v| v * v).sum();
        let column = |k: usize, h: f64| -> Option<DVector<f64>> {
            let r = residuals.get(k)?.as_ref()?;
            (r.len() == m).then(|| DVector::from_iterator(m, r.iter().zip(r0).map(|(a, b)| (a - b) / h)))
        };
        let r0v = DVector::from_column_slice(r0);
        // The base Jacobian; a failed base point leaves its column out.
        let (base_index, base): (Vec<usize>, Vec<DVector<f64>>) =
            self.base_steps.iter().enumerate().filter_map(|(k, &(i, h))| column(1 + k, h).map(|c| (i, c))).unzip();
        let drop_base = projected_norm2(&base, &r0v).map(|(d, _)| d).unwrap_or(0.0);
        let mut next = 1 + self.base_steps.len();
        let mut out = vec![];
        let point = &self.points[0];
        for (range, steps) in &self.strengths {
            let cols: Option<Vec<DVector<f64>>> =
                steps.iter().enumerate().map(|(j, &(_, h))| column(next + j, h)).collect();
            next += steps.len();
            let Some(cols) = cols else {
                out.push(failed());
                continue;
            };
            // A strength whose neutral value is a bound (a friction cannot be negative) may only
            // move away from it: a direction the step would take the wrong way is dropped and
            // the rest solved again, so the prediction is that of the effect as it can be fitted.
            let sign = |i: usize| {
                if self.lower[i] >= point[i] {
                    1.0
                } else if self.upper[i] <= point[i] {
                    -1.0
                } else {
                    0.0
                }
            };
            let mut active: Vec<usize> = (0..steps.len()).collect();
            let (drop_all, delta) = loop {
                let all: Vec<DVector<f64>> =
                    base.iter().cloned().chain(active.iter().map(|&j| cols[j].clone())).collect();
                let Some((drop_all, delta)) = projected_norm2(&all, &r0v) else { break (f64::NAN, DVector::zeros(0)) };
                let wrong: Vec<usize> = active
                    .iter()
                    .enumerate()
                    .filter(|(a, j)| sign(steps[**j].0) * delta[base.len() + a] < 0.0)
                    .map(|(_, j)| *j)
                    .collect();
                if wrong.is_empty() {
                    break (drop_all, delta);
                }
                active.retain(|j| !wrong.contains(j));
            };
            if drop_all.is_nan() {
                out.push(failed());
                continue;
            }
            if !ssr.is_finite() {
                out.push(failed());
                continue;
            }
            let d = (drop_all - drop_base).clamp(0.0, ssr);
            // The score test has one degree of freedom per strength; the information criterion
            // charges for every parameter the fit will have, as the decision does.
            let (q, count) = (steps.len() as f64, range.len());
            let score = if ssr > 0.0 { n_eff * d / ssr } else { 0.0 };
            let penalty = count as f64 * n_eff.max(1.0).ln();
            let ic = if ssr > 0.0 && d < ssr {
                n_eff * ((ssr - d) / ssr).ln() + penalty
            } else if ssr > 0.0 {
                f64::NEG_INFINITY
            } else {
                penalty // nothing left to explain
            };
            let mut estimate: Vec<f64> = point[range.clone()].to_vec();
            for (a, &j) in active.iter().enumerate() {
                let i = steps[j].0;
                estimate[i - range.start] = point[i] + delta[base.len() + a];
            }
            let mut base_step = vec![0.0; self.candidates_start()];
            for (j, &i) in base_index.iter().enumerate() {
                base_step[i] = delta[j];
            }
            out.push(Screened {
                predicted_drop: d,
                base_step,
                score,
                p_value: chi_squared_survival(score, q),
                predicted_delta_ic: ic,
                estimate,
            });
        }
        out
    }

    /// Points of candidate `c`'s model (the other candidates neutral) a `fraction` of the way
    /// along its Gauss–Newton step `s`, every value clipped into its bounds: where its fit may
    /// start. The base parameters come first, in the base's order.
    pub fn along_step(&self, c: usize, s: &Screened, fraction: f64) -> Vec<f64> {
        let mut p = self.points[0].clone();
        let offset = self.strengths[c].0.start;
        for (i, d) in s.base_step.iter().enumerate() {
            p[i] += fraction * d;
        }
        for (j, e) in s.estimate.iter().enumerate() {
            let i = offset + j;
            if e.is_finite() {
                p[i] += fraction * (e - p[i]);
            }
        }
        for (i, v) in p.iter_mut().enumerate() {
            *v = v.clamp(self.lower[i], self.upper[i]);
        }
        p
    }

    /// The base part and candidate `c`'s part of a point of the screening job.
    pub fn split(&self, c: usize, point: &[f64]) -> (Vec<f64>, Vec<f64>) {
        (point[..self.candidates_start()].to_vec(), point[self.strengths[c].0.clone()].to_vec())
    }

    /// Where the candidates' parameters start in a point: after the base's.
    fn candidates_start(&self) -> usize {
        self.strengths.first().map_or(self.points[0].len(), |(r, _)| r.start)
    }
}

/// ‖P r‖² for the projection P onto the span of `columns`, and the least-squares step δ with
/// J·δ ≈ −r (columns scaled to unit length first; directions below 1e-3 of the largest singular
/// value are left out: a candidate whose sensitivity all but repeats a base parameter's, such
/// as viscous damping beside the model's own viscous friction, then adds nothing instead of
/// a large step along the difference of two finite-difference errors). `None` if a column is
/// not finite.
fn projected_norm2(columns: &[DVector<f64>], r: &DVector<f64>) -> Option<(f64, DVector<f64>)> {
    if columns.is_empty() {
        return Some((0.0, DVector::zeros(0)));
    }
    if columns.iter().any(|c| c.iter().any(|v| !v.is_finite())) {
        return None;
    }
    let norms: Vec<f64> = columns.iter().map(|c| c.norm()).collect();
    let scaled: Vec<DVector<f64>> =
        columns.iter().zip(&norms).map(|(c, n)| if *n > 0.0 { c / *n } else { c.clone() }).collect();
    let j = DMatrix::from_columns(&scaled);
    let svd = j.clone().svd(true, true);
    let eps = 1e-3 * svd.singular_values.max();
    let step = svd.solve(&(-r), eps).ok()?;
    let fitted = &j * &step;
    let delta =
        DVector::from_iterator(step.len(), step.iter().zip(&norms).map(|(s, n)| if *n > 0.0 { s / n } else { 0.0 }));
    Some((fitted.norm_squared(), delta))
}

/// Indices of `screened` in ranking order: the most negative predicted information change
/// first; NaN (a failed screening) last, in generation order.
pub fn ranking(screened: &[Screened]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..screened.len()).collect();
    order.sort_by(|&a, &b| {
        let (x, y) = (screened[a].predicted_delta_ic, screened[b].predicted_delta_ic);
        match (x.is_nan(), y.is_nan()) {
            (false, false) => x.total_cmp(&y).then(a.cmp(&b)),
            (nx, ny) => nx.cmp(&ny).then(a.cmp(&b)),
        }
    });
    order
}

/// A series effect's kind, if `kind` names one (used to tell sensors from ports).
pub fn is_series(kind: &str) -> bool {
    matches!(effects::find(kind), Ok(Found::Series(_)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A linear "model": the residual of the base is r0 = y_b − data, with a known extra
    /// column; the screening's drop must equal the exact least-squares drop.
    #[test]
    fn the_predicted_drop_is_the_exact_least_squares_drop_for_a_linear_residual() {
        let m = 50;
        let t: Vec<f64> = (0..m).map(|k| k as f64 / m as f64).collect();
        // Residual = 0.3·sin(6t) (the missing effect) + a part along the base direction that
        // the base optimum already removed (orthogonal by construction: none).
        let r0 = DVector::from_iterator(m, t.iter().map(|t| 0.3 * (6.0 * t).sin()));
        let base = vec![DVector::from_iterator(m, t.iter().map(|t| *t))];
        let effect = DVector::from_iterator(m, t.iter().map(|t| (6.0 * t).sin()));
        let (with_base, _) = projected_norm2(&base, &r0).unwrap();
        let (all, delta) = projected_norm2(&[base[0].clone(), effect.clone()], &r0).unwrap();
        // Exact: regress r0 on [t, sin 6t].
        let j = DMatrix::from_columns(&[base[0].clone(), effect]);
        let beta = (j.transpose() * &j).try_inverse().unwrap() * j.transpose() * &r0;
        let exact = (&j * &beta).norm_squared();
        assert!((all - exact).abs() < 1e-10 * exact, "{all} vs {exact}");
        assert!(with_base < all);
        assert!((delta[1] + beta[1]).abs() < 1e-9, "{delta} vs {beta}");
    }

    /// A base job with one parameter `k` in [0, 2] and two sensor-offset candidates on its
    /// output, screened against a linear "model": the residual moves by `J·δ` exactly.
    #[test]
    fn screening_a_linear_residual_predicts_the_drop_and_a_failed_point_ranks_last() {
        let text = include_str!("../../tests/data/minimal_job.toml");
        let base = JobSpec::from_toml(text, std::path::Path::new("/")).unwrap();
        let stats = SignalStats::of(&[0.0, 1.0]);
        let sizes =
            Sizes { series: [("y".to_owned(), stats)].into(), duration: 1.0, sample: 0.1, ..Default::default() };
        let diagnose = DiagnoseSpec::default();
        let all = generate(&base, &diagnose, &Places::default(), &sizes);
        let offset = all.iter().find(|c| c.effect.kind == "sensor_offset").unwrap().clone();
        let candidates = vec![offset.clone(), offset];
        let s = Screening::new(&base, &[1.0], &candidates, false);
        // Points: base, k + h, offset₁ + step, offset₂ + step.
        assert_eq!(s.points.len(), 4);
        let m = 20;
        let t: Vec<f64> = (0..m).map(|i| i as f64 / m as f64).collect();
        // Residual: 0.3 (a constant the offset explains) plus 0.1·t (what k moves).
        let r0: Vec<f64> = t.iter().map(|t| 0.3 + 0.05 * (t - 0.5)).collect();
        let h_k = s.points[1][0] - 1.0;
        let h_o = s.points[2][1] - s.points[0][1];
        let rk: Vec<f64> = r0.iter().zip(&t).map(|(r, t)| r + h_k * 0.1 * t).collect();
        let ro: Vec<f64> = r0.iter().map(|r| r + h_o).collect();
        let ok = s.statistics(&[Some(r0.clone()), Some(rk.clone()), Some(ro.clone()), Some(ro.clone())], 10.0);
        // r0 = 0.275 + 0.05·t lies in the span of [0.1·t, 1]: the step is δk = −0.5 and
        // δoffset = −0.275, and the drop is all that the base direction alone leaves,
        // SSR − (t·r0)²/(t·t).
        let ssr: f64 = r0.iter().map(|r| r * r).sum();
        let tr: f64 = t.iter().zip(&r0).map(|(a, b)| a * b).sum();
        let tt: f64 = t.iter().map(|a| a * a).sum();
        let drop = ssr - tr * tr / tt;
        assert!((ok[0].predicted_drop - drop).abs() < 1e-9 * drop, "{} vs {drop}", ok[0].predicted_drop);
        assert!((ok[0].estimate[0] + 0.275).abs() < 1e-9 && (ok[0].base_step[0] + 0.5).abs() < 1e-9, "{ok:?}");
        // The second candidate's point failed: NaN statistics, ranked last, not fitted.
        let failed = s.statistics(&[Some(r0), Some(rk), Some(ro), None], 10.0);
        assert!(failed[1].predicted_delta_ic.is_nan());
        assert_eq!(ranking(&failed), [0, 1]);
        assert!(failed[0].predicted_delta_ic < 0.0);
    }

    /// A job with one output `x` and nothing else, to add candidates to.
    fn one_output_job() -> JobSpec {
        let text =
            "[model]\npath = \"m.fmu\"\n[data]\npath = \"d.csv\"\n[[outputs]]\nvariable = \"x\"\ncolumn = \"x\"\n";
        JobSpec::from_toml(text, std::path::Path::new("/")).unwrap()
    }

    #[test]
    fn each_state_gets_the_kinds_of_its_quantity_and_springs_read_its_position() {
        use crate::places::StatePlace;
        let base = one_output_job();
        let stats = SignalStats::of(&[-1.0, 1.0]);
        let names = ["x", "v", "w", "T", "c"];
        let sizes = Sizes {
            signals: names.iter().map(|n| (n.to_string(), stats)).collect(),
            state_scales: names.iter().map(|n| (n.to_string(), 0.5)).collect(),
            duration: 1.0,
            sample: 0.1,
            ..Default::default()
        };
        let place = |state: &str, role: Role, position: Option<&str>| StatePlace {
            state: state.into(),
            role,
            position: position.map(str::to_owned),
            coupled: vec![],
        };
        let places = Places {
            states: vec![
                place("v", Role::Velocity, Some("x")),
                place("w", Role::Velocity, None),
                place("T", Role::Temperature, None),
                place("c", Role::Other, None),
            ],
            ..Default::default()
        };
        let diagnose = DiagnoseSpec { series: false, ..Default::default() };
        let all = generate(&base, &diagnose, &places, &sizes);
        let at = |state: &str| -> Vec<String> {
            all.iter().filter(|c| c.effect.state.as_deref() == Some(state)).map(|c| c.describe()).collect()
        };
        assert_eq!(
            at("v"),
            [
                "viscous_damping on der(v)",
                "coulomb_friction on der(v)",
                "stribeck_friction on der(v)",
                "quadratic_drag on der(v)",
                "linear_spring of x on der(v)",
                "cubic_spring of x on der(v)",
                "constant_load on der(v)",
                "dead_zone_spring of x on der(v)",
            ]
        );
        // Without a position, no spring.
        assert_eq!(at("w").len(), 5);
        assert_eq!(at("T"), ["convection on der(T)", "radiation on der(T)", "heat_loss on der(T)"]);
        assert_eq!(at("c"), ["linear_relaxation on der(c)", "constant_rate on der(c)"]);
        assert!(all.iter().all(|c| c.place().starts_with("der(") && c.source.starts_with("model state ")));
        // Strength steps come from the state's derivative scale: a constant rate's is a tenth.
        let rate = all.iter().find(|c| c.effect.kind == "constant_rate").unwrap();
        assert_eq!(rate.guesses[0].step, Some(0.05));
    }

    #[test]
    fn a_coupled_velocity_gets_friction_damping_and_drag_with_a_reaction_of_either_sign() {
        use crate::places::StatePlace;
        let base = one_output_job();
        let stats = SignalStats::of(&[-1.0, 1.0]);
        let sizes = Sizes {
            signals: ["v", "w"].iter().map(|n| (n.to_string(), stats)).collect(),
            // The coupled joint's derivative moves the outputs at a tenth of the scale.
            state_scales: [("v".to_owned(), 0.5), ("w".to_owned(), 5.0)].into(),
            duration: 1.0,
            sample: 0.1,
            ..Default::default()
        };
        let places = Places {
            states: vec![StatePlace {
                state: "v".into(),
                role: Role::Velocity,
                position: None,
                coupled: vec!["w".into()],
            }],
            ..Default::default()
        };
        let all = generate(&base, &DiagnoseSpec { series: false, ..Default::default() }, &places, &sizes);
        let words: Vec<String> = all.iter().map(Candidate::describe).collect();
        assert_eq!(
            words,
            [
                "viscous_damping on der(v)",
                "viscous_damping on der(v) and its reaction on der(w)",
                "coulomb_friction on der(v)",
                "coulomb_friction on der(v) and its reaction on der(w)",
                "stribeck_friction on der(v)",
                "quadratic_drag on der(v)",
                "quadratic_drag on der(v) and its reaction on der(w)",
                "constant_load on der(v)",
            ]
        );
        let coulomb = &all[3];
        assert_eq!(coulomb.parameter_names(), ["force", "reaction"]);
        assert_eq!(coulomb.place(), "der(v)");
        // The reaction is sized by w's scale, of either sign, neutral at 0.
        let (own, reaction) = (coulomb.guesses[0], coulomb.guesses[1]);
        assert_eq!((reaction.neutral, reaction.lower, reaction.upper), (0.0, -10.0 * own.upper, 10.0 * own.upper));
        assert_eq!(coulomb.effect.parameters["reaction"].lower, reaction.lower);
        // The job it makes is valid.
        let mut job = base.clone();
        job.effects.push(coulomb.effect.clone());
        job.validate().unwrap();
        assert_eq!(job.parameter_vectors().0, ["effects[0].force", "effects[0].reaction"]);
    }

    #[test]
    fn ranking_puts_failed_screenings_last() {
        let s = |ic: f64| Screened {
            predicted_drop: 0.0,
            score: 0.0,
            p_value: 1.0,
            predicted_delta_ic: ic,
            estimate: vec![],
            base_step: vec![],
        };
        let order = ranking(&[s(f64::NAN), s(-3.0), s(2.0), s(-10.0), s(f64::NAN)]);
        assert_eq!(order, [3, 1, 2, 0, 4]);
    }
}
