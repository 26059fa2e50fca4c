//! The size of what each place can add, where the job does not give it: for a port, the
//! constant load on it that moves the outputs about as much as the residual is large; for a
//! state, the constant rate added to its derivative that does. One job that evaluates points
//! adds a `constant_load` (mechanical port), `heat_loss` (thermal port) or `constant_rate`
//! (state) effect at every such place and tries a size at each alone; the response is linear
//! in a small size, so one that was too small or too large is rescaled and tried again, at
//! most a few times. A place found in the model (not listed by hand) that cannot be sized is
//! dropped with a note; one listed by hand is an error.

use std::collections::BTreeMap;

use fmucal_shared::job::JobSpec;
use fmucal_shared::job::spec::{Bounds, EffectSpec};

use super::{Context, Evaluate};
use crate::error::{Error, bail};
use crate::places::Places;
use crate::spec::PortDomain;

/// Accepted ratios of the response's RMS to the residual's.
const ACCEPTED: std::ops::RangeInclusive<f64> = 1e-3..=10.0;
/// The ratio a rescaled size aims at.
const AIM: f64 = 0.1;
const ATTEMPTS: usize = 5;

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// What the probe found.
#[derive(Debug, Default)]
pub struct Probed {
    pub port_scales: BTreeMap<String, f64>,
    pub state_scales: BTreeMap<String, f64>,
    /// Places found in the model that could not be sized, in words.
    pub notes: Vec<String>,
    pub simulations: u64,
}

/// One place to probe.
struct Place {
    /// The port or state.
    name: String,
    is_state: bool,
    /// Where an error points (`diagnose.ports[1].scale`), for a place listed by hand.
    field: Option<String>,
    effect: EffectSpec,
}

/// The scale of every place of `places`, given or probed around the base optimum `x_base`
/// of `base`.
pub async fn scales(
    eval: &mut impl Evaluate,
    ctx: &Context,
    places: &Places,
    base: &JobSpec,
    x_base: &[f64],
) -> Result<Probed, Error> {
    let mut out = Probed {
        port_scales: places.ports.iter().filter_map(|p| p.spec.scale.map(|s| (p.spec.port.clone(), s))).collect(),
        ..Probed::default()
    };
    let load = Bounds { start: 0.0, lower: -1e30, upper: 1e30 };
    let mut probed: Vec<Place> = vec![];
    for p in places.ports.iter().filter(|p| p.spec.scale.is_none()) {
        let Some((_, signal)) = p.spec.signals().next() else { continue };
        let (kind, parameter) = match p.spec.domain {
            PortDomain::Mechanical => ("constant_load", "load"),
            PortDomain::Thermal => ("heat_loss", "q"),
        };
        probed.push(Place {
            name: p.spec.port.clone(),
            is_state: false,
            field: p.by_hand.then(|| format!("{}.scale", p.source)),
            effect: EffectSpec {
                kind: kind.into(),
                port: Some(p.spec.port.clone()),
                signal: Some(signal.to_owned()),
                parameters: [(parameter.to_owned(), load)].into(),
                ..EffectSpec::default()
            },
        });
    }
    for s in &places.states {
        probed.push(Place {
            name: s.state.clone(),
            is_state: true,
            field: None,
            effect: EffectSpec {
                kind: "constant_rate".into(),
                state: Some(s.state.clone()),
                parameters: [("rate".to_owned(), load)].into(),
                ..EffectSpec::default()
            },
        });
    }
    if probed.is_empty() {
        return Ok(out);
    }
    let mut job = base.clone();
    job.diagnose = None;
    job.effects.extend(probed.iter().map(|p| p.effect.clone()));
    let n = x_base.len();
    let mut sizes = vec![1e-3; probed.len()];
    let mut done = vec![false; probed.len()];
    for _ in 0..ATTEMPTS {
        let mut x0 = x_base.to_vec();
        x0.extend(std::iter::repeat_n(0.0, probed.len()));
        let mut points = vec![x0.clone()];
        for (k, size) in sizes.iter().enumerate().filter(|(k, _)| !done[*k]) {
            let mut p = x0.clone();
            p[n + k] = *size;
            points.push(p);
        }
        out.simulations += points.len() as u64;
        let evaluated = eval.evaluate(&job, points, &ctx.data, &ctx.model).await?;
        let Some(r0) = evaluated.first().filter(|e| e.value.is_some()).map(|e| &e.residuals) else {
            let why = evaluated.first().map_or("no point was evaluated", |e| e.message.as_str());
            bail!("the probe of the places' scales failed at the base optimum: {why}");
        };
        let residual = rms(r0).max(f64::MIN_POSITIVE);
        let open: Vec<usize> = (0..probed.len()).filter(|k| !done[*k]).collect();
        for (k, e) in open.into_iter().zip(&evaluated[1..]) {
            let ratio = match e.value {
                Some(_) if e.residuals.len() == r0.len() => {
                    let d: Vec<f64> = e.residuals.iter().zip(r0).map(|(a, b)| a - b).collect();
                    rms(&d) / residual
                }
                _ => f64::INFINITY, // the size broke the simulation: far too large
            };
            if ACCEPTED.contains(&ratio) {
                let scale = sizes[k] / ratio;
                let map = if probed[k].is_state { &mut out.state_scales } else { &mut out.port_scales };
                map.insert(probed[k].name.clone(), scale);
                done[k] = true;
            } else if ratio > 0.0 && ratio.is_finite() {
                sizes[k] *= AIM / ratio;
            } else if ratio == 0.0 {
                sizes[k] *= 1e3;
            } else {
                sizes[k] *= 1e-3;
            }
        }
        if done.iter().all(|d| *d) {
            break;
        }
    }
    for p in probed.iter().zip(&done).filter(|(_, d)| !**d).map(|(p, _)| p) {
        match &p.field {
            Some(field) => bail!(
                "{field}: a constant load on {:?} could not be sized to the residual; give the typical size of what the port adds",
                p.name
            ),
            None if p.is_state => out.notes.push(format!(
                "state {}: no constant rate on its derivative moves the outputs measurably: no state effects there",
                p.name
            )),
            None => out.notes.push(format!(
                "input {}: no constant load on it moves the outputs measurably: no port effects there",
                p.name
            )),
        }
    }
    Ok(out)
}
