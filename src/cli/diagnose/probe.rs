//! The load scale of each port that does not give one: the constant load on the port that
//! moves the outputs about as much as the residual is large. One job that evaluates points
//! adds a `constant_load` (mechanical) or `heat_loss` (thermal) effect on every such port and tries a load on each alone; the
//! response is linear in a small load, so a load that was too small or too large is rescaled
//! and tried again, at most a few times.

use std::collections::BTreeMap;

use anyhow::{Result, bail};
use fmucal_shared::diagnose::spec::PortDomain;
use fmucal_shared::job::JobSpec;
use fmucal_shared::job::spec::{Bounds, EffectSpec};

use super::Context;
use crate::cli::client::Client;

/// Accepted ratios of the response's RMS to the residual's.
const ACCEPTED: std::ops::RangeInclusive<f64> = 1e-3..=10.0;
/// The ratio a rescaled load aims at.
const AIM: f64 = 0.1;
const ATTEMPTS: usize = 5;

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// The load scale of every port of the `[diagnose]` section, given or probed around the base
/// optimum `x_base` of `base`, and the simulations the probe ran.
pub async fn port_scales(
    client: &mut Client,
    ctx: &Context,
    base: &JobSpec,
    x_base: &[f64],
) -> Result<(BTreeMap<String, f64>, u64)> {
    let mut scales: BTreeMap<String, f64> =
        ctx.settings.ports.iter().filter_map(|p| p.scale.map(|s| (p.port.clone(), s))).collect();
    let probed: Vec<(usize, &str, &str, PortDomain)> = ctx
        .settings
        .ports
        .iter()
        .enumerate()
        .filter(|(_, p)| p.scale.is_none())
        .filter_map(|(k, p)| p.signals().next().map(|(_, s)| (k, p.port.as_str(), s, p.domain)))
        .collect();
    if probed.is_empty() {
        return Ok((scales, 0));
    }
    let mut job = base.clone();
    job.diagnose = None;
    for (_, port, signal, domain) in &probed {
        let load = Bounds { start: 0.0, lower: -1e30, upper: 1e30 };
        let (kind, parameter) = match domain {
            PortDomain::Mechanical => ("constant_load", "load"),
            PortDomain::Thermal => ("heat_loss", "q"),
        };
        job.effects.push(EffectSpec {
            kind: kind.into(),
            port: Some((*port).to_owned()),
            signal: Some((*signal).to_owned()),
            output: None,
            input: None,
            parameters: [(parameter.to_owned(), load)].into(),
        });
    }
    let n = x_base.len();
    let mut loads = vec![1e-3; probed.len()];
    let mut done = vec![false; probed.len()];
    let mut simulations = 0;
    for _ in 0..ATTEMPTS {
        let mut x0 = x_base.to_vec();
        x0.extend(std::iter::repeat_n(0.0, probed.len()));
        let mut points = vec![x0.clone()];
        for (k, load) in loads.iter().enumerate() {
            let mut p = x0.clone();
            p[n + k] = *load;
            points.push(p);
        }
        simulations += points.len() as u64;
        let evaluated = client.evaluate(&job, points, std::slice::from_ref(&*ctx.data), &ctx.model).await?;
        let Some(r0) = evaluated.first().filter(|e| e.value.is_some()).map(|e| &e.residuals) else {
            let why = evaluated.first().map_or("no point was evaluated", |e| e.message.as_str());
            bail!("the probe of the ports' load scales failed at the base optimum: {why}");
        };
        let residual = rms(r0).max(f64::MIN_POSITIVE);
        for (k, e) in evaluated[1..].iter().enumerate() {
            if done[k] {
                continue;
            }
            let ratio = match e.value {
                Some(_) if e.residuals.len() == r0.len() => {
                    let d: Vec<f64> = e.residuals.iter().zip(r0).map(|(a, b)| a - b).collect();
                    rms(&d) / residual
                }
                _ => f64::INFINITY, // the load broke the simulation: far too large
            };
            if ACCEPTED.contains(&ratio) {
                scales.insert(probed[k].1.to_owned(), loads[k] / ratio);
                done[k] = true;
            } else if ratio > 0.0 && ratio.is_finite() {
                loads[k] *= AIM / ratio;
            } else if ratio == 0.0 {
                loads[k] *= 1e3;
            } else {
                loads[k] *= 1e-3;
            }
        }
        if done.iter().all(|d| *d) {
            return Ok((scales, simulations));
        }
    }
    let (k, port, _, _) = probed[done.iter().position(|d| !d).expect("one is not done")];
    bail!(
        "diagnose.ports[{k}].scale: a constant load on {port:?} could not be sized to the residual; give the typical size of what the port adds"
    )
}
