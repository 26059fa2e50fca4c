//! What `fmucal diagnose` checks before any model code runs: the windows (the job's validation
//! window, or a holdout cut from its calibration window), the job against its model and data,
//! and every candidate the `[diagnose]` section would generate — ports that are real inputs of
//! the right domain, signals that can be read, no algebraic loop — each refused in one line
//! naming the `[diagnose]` field.

use std::collections::BTreeMap;

use anyhow::{Result, bail};
use fmucal_shared::diagnose::candidates::{Sizes, generate};
use fmucal_shared::diagnose::guess::SignalStats;
use fmucal_shared::diagnose::report::Windows;
use fmucal_shared::diagnose::spec::{DEFAULT_HOLDOUT, DiagnoseSpec};
use fmucal_shared::fmu::Fmu;
use fmucal_shared::job::{JobError, JobSpec, MeasurementTable, PreparedJob};

/// The windows of the diagnosis. With a validation window in the job, fits use the job's
/// calibration window and decisions its validation window; without one, the last `holdout`
/// fraction of the calibration window is held out of every fit (`spec` is changed to say so).
///
/// # Errors
/// If the holdout leaves no measurement on either side.
pub fn windows(spec: &mut JobSpec, data: &MeasurementTable, settings: &DiagnoseSpec) -> Result<Windows> {
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

/// Stand-in sizes under which every signal the section names yields its candidates.
fn any_sizes(spec: &JobSpec, settings: &DiagnoseSpec) -> Sizes {
    let unit = SignalStats::of(&[0.0, 1.0]);
    let signals: BTreeMap<String, SignalStats> =
        settings.ports.iter().flat_map(|p| p.signals().map(|(_, s)| (s.to_owned(), unit))).collect();
    let series = spec
        .outputs
        .iter()
        .map(|o| o.variable.clone())
        .chain(spec.inputs.iter().map(|i| i.variable.clone()))
        .map(|v| (v, unit))
        .collect();
    Sizes { port_scales: BTreeMap::new(), signals, series, duration: 1.0, sample: 0.1 }
}

/// Checks the job and every candidate against the model description and the data.
///
/// # Errors
/// The job's own error, or one naming the `[diagnose]` field a bad candidate comes from.
pub fn job_and_candidates(spec: &JobSpec, settings: &DiagnoseSpec, fmu: &Fmu, data: &MeasurementTable) -> Result<()> {
    let md = &fmu.description;
    PreparedJob::new(spec, md, &fmu.interfaces(), std::slice::from_ref(data))?;
    fmucal_shared::job::optimizer::build(spec)?;
    for (k, s) in settings.signals.iter().enumerate() {
        if md.variable(s).is_none() {
            bail!("diagnose.signals[{k}]: {s:?} is not a variable of the model");
        }
    }
    // Each candidate alone, so an error names the one at fault.
    let candidates = generate(spec, settings, &any_sizes(spec, settings));
    let mut checked: Vec<(String, Option<String>, Option<String>)> = vec![];
    for c in &candidates {
        let key = (c.effect.kind.clone(), c.effect.port.clone(), c.effect.signal.clone());
        if c.effect.port.is_none() || checked.contains(&key) {
            continue;
        }
        checked.push(key);
        let mut one = spec.clone();
        one.effects.push(c.effect.clone());
        if let Err(e) = PreparedJob::new(&one, md, &fmu.interfaces(), std::slice::from_ref(data)) {
            let message = match e {
                JobError::Invalid { message, .. } => message,
                other => other.to_string(),
            };
            // A fault of the port itself is the port's, not that of the signal it was tried with.
            let port_field = c.effect.port.as_ref().filter(|_| message.starts_with("port ")).and_then(|port| {
                settings.ports.iter().position(|p| &p.port == port).map(|k| format!("diagnose.ports[{k}].port"))
            });
            bail!("{}: {message} (candidate {})", port_field.as_deref().unwrap_or(&c.source), c.describe());
        }
    }
    Ok(())
}
