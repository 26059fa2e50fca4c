//! Co-Simulation driver (FMI 2.0 section 4): steps with `fmi2DoStep` so that every output time
//! is a communication point, splitting intervals longer than the maximum step. Inputs are set
//! at the start of each step; if the FMU can handle variable communication steps, a step also
//! ends where an input jumps or a held input changes, so the change applies on time (as FMPy
//! does). `fmi2Discard` ends the run early if the FMU terminated (with a
//! last row at `fmi2LastSuccessfulTime`, as FMPy records it), or resumes from
//! `fmi2LastSuccessfulTime`; `fmi2Error`/`fmi2Fatal` are errors naming the time.

use super::inputs::Side;
use super::plan::Plan;
use super::spec::{SimError, SimResult};
use super::{Recorder, initialize, time_eps};
use crate::fmu::{Instance, Status};

pub(super) fn run(inst: &mut Instance, plan: &Plan) -> Result<SimResult, SimError> {
    initialize(inst, plan)?;
    let mut rec = Recorder::new(plan);
    let mut t = plan.start;
    let mut steps: u64 = 0;
    let variable_steps =
        inst.description().co_simulation.as_ref().is_some_and(|cs| cs.can_handle_variable_communication_step_size);
    let held = plan.held_columns();
    let input_event_after = |t: f64| match &plan.inputs {
        Some(table) if variable_steps => table.next_breakpoint(t, &held),
        _ => None,
    };
    for &target in &plan.grid {
        while t < target - time_eps(target) {
            let step_end = match input_event_after(t) {
                Some(b) if b < target - time_eps(target) => b,
                _ => target,
            };
            let remaining = step_end - t;
            let h = match plan.max_step {
                Some(m) if remaining > m * (1.0 + 1e-12) => m,
                _ => remaining,
            };
            plan.set_inputs(inst, t)?;
            plan.apply_port_terms(inst, t, Side::Right)?;
            inst.set_error_time(t);
            steps += 1;
            plan.check_budget(steps, t)?;
            let status = inst.call("fmi2DoStep", |c| c.do_step(t, h))?;
            if status == Status::Discard {
                let c = inst.component()?;
                let last_successful = c.last_successful_time();
                if c.terminated().unwrap_or(false) {
                    // The values at the last successful time are the FMU's last word.
                    let recorded = rec.time.last().copied().unwrap_or(f64::NEG_INFINITY);
                    if let Some(last) =
                        last_successful.filter(|&l| l > recorded + time_eps(l) && l <= target + time_eps(target))
                    {
                        inst.set_error_time(last);
                        rec.record(inst, plan, last)?;
                    }
                    tracing::info!(time = last_successful.unwrap_or(t), "the FMU terminated the simulation");
                    return Ok(rec.finish(steps, 0, true));
                }
                match last_successful {
                    Some(last) if last > t => {
                        t = last;
                        continue;
                    }
                    _ => {
                        return Err(SimError::Solver {
                            time: t,
                            message: "fmi2DoStep returned fmi2Discard without progress or termination".into(),
                        });
                    }
                }
            }
            t = if h == remaining { step_end } else { t + h };
        }
        t = t.max(target);
        rec.record(inst, plan, target)?;
    }
    Ok(rec.finish(steps, 0, false))
}
