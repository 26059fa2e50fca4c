//! Co-Simulation driver (FMI 2.0 section 4): steps with `fmi2DoStep` so that every output time
//! is a communication point, splitting intervals longer than the maximum step. Inputs are set
//! at the start of each step. `fmi2Discard` ends the run early if the FMU terminated, or resumes
//! from `fmi2LastSuccessfulTime`; `fmi2Error`/`fmi2Fatal` are errors naming the time.

use super::plan::Plan;
use super::spec::{SimError, SimResult};
use super::{Recorder, initialize};
use crate::fmu::{Instance, Status};

pub(super) fn run(inst: &mut Instance, plan: &Plan) -> Result<SimResult, SimError> {
    initialize(inst, plan)?;
    let mut rec = Recorder::new(plan);
    let mut t = plan.start;
    let mut steps: u64 = 0;
    let eps = |x: f64| 1e-12 * x.abs().max(1.0);
    for &target in &plan.grid {
        while t < target - eps(target) {
            let remaining = target - t;
            let h = match plan.max_step {
                Some(m) if remaining > m * (1.0 + 1e-12) => m,
                _ => remaining,
            };
            plan.set_inputs(inst, t)?;
            inst.set_error_time(t);
            steps += 1;
            plan.check_budget(steps, t)?;
            let status = inst.call("fmi2DoStep", |c| c.do_step(t, h))?;
            if status == Status::Discard {
                let c = inst.component()?;
                if c.terminated().unwrap_or(false) {
                    tracing::info!(time = t, "the FMU terminated the simulation");
                    return Ok(rec.finish(steps, 0, true));
                }
                match c.last_successful_time() {
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
            t = if h == remaining { target } else { t + h };
        }
        t = t.max(target);
        rec.record(inst, plan, target)?;
    }
    Ok(rec.finish(steps, 0, false))
}
