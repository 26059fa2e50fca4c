//! What a diagnosis checks before any model code runs: the windows (the job's validation
//! window, or a holdout cut from its calibration window), the job against its model and data,
//! and every candidate the diagnosis would generate — ports that are real inputs of the right
//! domain, signals that can be read, no algebraic loop, states that are continuous states.
//! A candidate from the `[diagnose]` section is refused in one line naming its field; a place
//! found in the model's structure that the model refuses is dropped with a note.

use std::collections::BTreeMap;

use fmucal_shared::effects::guess::SignalStats;
use fmucal_shared::fmu::{Fmu, Interface};
use fmucal_shared::job::{JobError, JobSpec, MeasurementTable, PreparedJob};
use fmucal_shared::quote::quote_user_text;
use fmucal_shared::structure::Structure;

use crate::candidates::{Sizes, generate};
use crate::error::{Error, bail};
use crate::places::Places;
use crate::report::Windows;
use crate::spec::{DEFAULT_HOLDOUT, DiagnoseSpec};

/// The windows of the diagnosis. With a validation window in the job, fits use the job's
/// calibration window and decisions its validation window; without one, the last `holdout`
/// fraction of the calibration window is held out of every fit (`spec` is changed to say so).
///
/// # Errors
/// If the holdout leaves no measurement on either side.
pub fn windows(spec: &mut JobSpec, data: &MeasurementTable, settings: &DiagnoseSpec) -> Result<Windows, Error> {
    let (first, last) = (data.time.first().copied().unwrap_or(0.0), data.time.last().copied().unwrap_or(0.0));
    let start = spec.simulation.start_time.unwrap_or(first);
    let stop = spec.simulation.stop_time.unwrap_or(last);
    if let Some(v) = spec.simulation.validation_stop_time {
        // The check `calibrate` and a coordinator make too.
        spec.simulation.check_validation_stop(stop)?;
        return Ok(Windows { start_time: start, calibration_stop: stop, validation_stop: v, holdout: false });
    }
    let fraction = settings.holdout.unwrap_or(DEFAULT_HOLDOUT);
    let cut = start + (1.0 - fraction) * (stop - start);
    let inside = |a: f64, b: f64| data.time.iter().filter(|t| **t > a && **t <= b).count();
    if inside(start, cut) < 2 || inside(cut, stop) < 2 {
        bail!(
            "diagnose.holdout: holding out the last {fraction} of [{start}, {stop}] leaves too few measurements on one side"
        );
    }
    spec.simulation.stop_time = Some(cut);
    spec.simulation.validation_stop_time = Some(stop);
    Ok(Windows { start_time: start, calibration_stop: cut, validation_stop: stop, holdout: true })
}

/// Stand-in sizes under which every place yields its candidates.
fn any_sizes(spec: &JobSpec, places: &Places) -> Sizes {
    let unit = SignalStats::of(&[0.0, 1.0]);
    let signals: BTreeMap<String, SignalStats> = places
        .ports
        .iter()
        .flat_map(|p| p.spec.signals().map(|(_, s)| (s.to_owned(), unit)))
        .chain(
            places.states.iter().flat_map(|s| std::iter::once(&s.state).chain(&s.position).map(|n| (n.clone(), unit))),
        )
        .collect();
    let series = spec
        .outputs
        .iter()
        .map(|o| o.variable.clone())
        .chain(spec.inputs.iter().map(|i| i.variable.clone()))
        .map(|v| (v, unit))
        .collect();
    let state_scales = places.states.iter().map(|s| (s.state.clone(), 1.0)).collect();
    let port_scales = places.ports.iter().map(|p| (p.spec.port.clone(), 1.0)).collect();
    Sizes { port_scales, state_scales, signals, series, duration: 1.0, sample: 0.1 }
}

/// The places of the diagnosis (ports by hand and from the model's structure, states in
/// Model Exchange), each candidate checked against the model description and the data. A
/// place found in the model whose candidates the model refuses (an input that feeds a signal
/// directly, say) is dropped with a note.
///
/// # Errors
/// The job's own error, or one naming the `[diagnose]` field a bad candidate or name comes from.
pub fn job_and_candidates(
    spec: &JobSpec,
    settings: &DiagnoseSpec,
    fmu: &Fmu,
    data: &MeasurementTable,
) -> Result<Places, Error> {
    let md = &fmu.description;
    let interfaces = fmu.interfaces();
    PreparedJob::new(spec, md, &interfaces, std::slice::from_ref(data))?;
    fmucal_shared::job::optimizer::build(spec)?;
    for (k, s) in settings.signals.iter().enumerate() {
        if md.variable(s).is_none() {
            bail!("diagnose.signals[{k}]: {} is not a variable of the model", quote_user_text(s));
        }
    }
    let mapped: Vec<String> = spec.inputs.iter().map(|i| i.variable.clone()).collect();
    let structure = Structure::read(md, &mapped);
    for (k, s) in settings.states.iter().flatten().enumerate() {
        if structure.state(s).is_none() {
            let names: Vec<&str> = structure.states.iter().map(|s| s.name.as_str()).collect();
            bail!(
                "diagnose.states[{k}]: {} is not a continuous state of the model (its states: {})",
                quote_user_text(s),
                if names.is_empty() { "none".to_owned() } else { quote_user_text(&names.join(", ")) }
            );
        }
    }
    for (k, s) in settings.exclude.iter().enumerate() {
        if md.variable(s).is_none() {
            bail!("diagnose.exclude[{k}]: {} is not a variable of the model", quote_user_text(s));
        }
    }
    let interface = spec.model.interface.or_else(|| interfaces.first().copied());
    let model_exchange = match interface {
        Some(Interface::ModelExchange) => Ok(()),
        _ if interfaces.contains(&Interface::ModelExchange) => {
            Err("the job simulates in Co-Simulation, where the FMU integrates its own states".to_owned())
        }
        _ => Err("Co-Simulation only".to_owned()),
    };
    let mut places = Places::new(spec, settings, &structure, model_exchange);
    // Each candidate alone, so an error names the one at fault.
    let candidates = generate(spec, settings, &places, &any_sizes(spec, &places));
    type Key = (String, Option<String>, Option<String>, Option<String>, Option<String>);
    let mut checked: Vec<Key> = vec![];
    let mut dropped: Vec<String> = vec![];
    // (state, coupled velocity) pairs whose reaction candidates fail: only those are left out.
    let mut no_reaction: Vec<(String, String)> = vec![];
    for c in &candidates {
        let e = &c.effect;
        let key = (e.kind.clone(), e.state.clone(), e.reaction.clone(), e.port.clone(), e.signal.clone());
        let place = c.place();
        if (e.port.is_none() && e.state.is_none()) || checked.contains(&key) || dropped.contains(&place) {
            continue;
        }
        checked.push(key);
        let mut one = spec.clone();
        one.effects.push(e.clone());
        if let Err(err) = PreparedJob::new(&one, md, &interfaces, std::slice::from_ref(data)) {
            let message = match err {
                JobError::Invalid { message, .. } => message,
                other => other.to_string(),
            };
            let by_hand = c.source.starts_with("diagnose.");
            if let (Some(state), Some(reaction)) = (&e.state, &e.reaction) {
                places.notes.push(format!("{place} with a reaction on der({reaction}): {message}: no reaction there"));
                no_reaction.push((state.clone(), reaction.clone()));
                continue;
            }
            if !by_hand {
                places.notes.push(format!("{place}: {message}: no effects there"));
                dropped.push(place);
                continue;
            }
            // A fault of the port itself is the port's, not that of the signal it was tried with.
            let port_field = e.port.as_ref().filter(|_| message.starts_with("port ")).and_then(|port| {
                settings.ports.iter().position(|p| &p.port == port).map(|k| format!("diagnose.ports[{k}].port"))
            });
            bail!("{}: {message} (candidate {})", port_field.as_deref().unwrap_or(&c.source), c.describe());
        }
    }
    places.ports.retain(|p| !dropped.contains(&format!("port {}", p.spec.port)));
    places.states.retain(|s| !dropped.contains(&format!("der({})", s.state)));
    for s in &mut places.states {
        s.coupled.retain(|r| !no_reaction.contains(&(s.state.clone(), r.clone())));
    }
    if candidates.is_empty() {
        bail!("diagnose: there is no candidate to try ({})", places.notes.join("; "));
    }
    Ok(places)
}
