//! Model Exchange driver (FMI 2.0 section 3) over diffsol's adaptive integrators.
//!
//! Between events the continuous states are integrated by diffsol (BDF by default; ESDIRK34,
//! TR-BDF2 or Tsit45 on request) with `rtol` from the plan and `atol = rtol * nominal` per
//! state, root-finding on the event indicators. The integrator stops at:
//! - state events (an indicator changes sign; diffsol locates the root),
//! - time events (`nextEventTimeDefined`), used as the integrator's stop time,
//! - step events (`fmi2CompletedIntegratorStep` asks for event mode),
//! - jumps and changes of held inputs, and the stop time.
//!
//! At each event the FMU goes through event mode and `fmi2NewDiscreteStates` until no new
//! discrete states are needed; if states changed the integrator restarts from the new states.
//! Outputs at the requested times come from diffsol's dense output, pushed into the FMU before
//! reading. The Jacobian the implicit methods need is a forward finite difference of
//! `fmi2GetDerivatives`.

use std::cell::{Cell, RefCell};

use diffsol::{NalgebraLU, NalgebraMat, OdeBuilder, OdeEquations, OdeSolverMethod, OdeSolverStopReason, Vector};

use super::inputs::Side;
use super::plan::Plan;
use super::spec::{SimError, SimResult, Solver};
use super::{Recorder, initialize};
use crate::fmu::ffi::EventInfo;
use crate::fmu::{FmuError, Instance};

/// The FMU as seen from diffsol's closures: shared, with the first error kept aside (closures
/// cannot return errors, so they fill their outputs with NaN and the driver reports the error).
struct Model<'a> {
    inst: RefCell<&'a mut Instance>,
    plan: &'a Plan,
    error: RefCell<Option<FmuError>>,
    rhs_evaluations: Cell<u64>,
    /// End of the segment being integrated.
    segment_end: Cell<f64>,
    nx: usize,
    nz: usize,
}

impl Model<'_> {
    fn failed(&self) -> bool {
        self.error.borrow().is_some()
    }

    fn keep(&self, r: Result<(), FmuError>, out: &mut [f64]) {
        if let Err(e) = r {
            out.fill(f64::NAN);
            let mut slot = self.error.borrow_mut();
            if slot.is_none() {
                *slot = Some(e);
            }
        }
    }

    /// Pushes time, continuous inputs and states into the FMU. Inside a segment the inputs at
    /// the segment's end are its left limit: a jump there belongs to the next segment.
    fn set_point(&self, inst: &mut Instance, t: f64, x: &[f64]) -> Result<(), FmuError> {
        inst.set_error_time(t);
        inst.call("fmi2SetTime", |c| c.set_time(t))?;
        let side = if t >= self.segment_end.get() { Side::Left } else { Side::Right };
        self.plan.set_inputs_from(inst, t, side, true)?;
        if !x.is_empty() {
            inst.call("fmi2SetContinuousStates", |c| c.set_continuous_states(x))?;
        }
        Ok(())
    }

    fn rhs(&self, x: &[f64], t: f64, dx: &mut [f64]) {
        if self.failed() {
            dx.fill(f64::NAN);
            return;
        }
        self.rhs_evaluations.set(self.rhs_evaluations.get() + 1);
        let mut inst = self.inst.borrow_mut();
        let r = self
            .set_point(&mut inst, t, x)
            .and_then(|_| inst.call("fmi2GetDerivatives", |c| c.get_derivatives(dx)).map(|_| ()));
        self.keep(r, dx);
    }

    /// Forward-difference Jacobian-vector product J(x) v.
    fn jac_vec(&self, x: &[f64], t: f64, v: &[f64], out: &mut [f64]) {
        let vnorm = v.iter().map(|a| a * a).sum::<f64>().sqrt();
        if vnorm == 0.0 {
            out.fill(0.0);
            return;
        }
        let xnorm = x.iter().map(|a| a * a).sum::<f64>().sqrt();
        let eps = f64::EPSILON.sqrt() * xnorm.max(1.0) / vnorm;
        let mut f0 = vec![0.0; x.len()];
        self.rhs(x, t, &mut f0);
        let xp: Vec<f64> = x.iter().zip(v).map(|(a, b)| a + eps * b).collect();
        self.rhs(&xp, t, out);
        for (o, f) in out.iter_mut().zip(&f0) {
            *o = (*o - f) / eps;
        }
    }

    fn indicators(&self, x: &[f64], t: f64, z: &mut [f64]) {
        if self.nz == 0 {
            z.fill(1.0);
            return;
        }
        if self.failed() {
            z.fill(f64::NAN);
            return;
        }
        let mut inst = self.inst.borrow_mut();
        let r = self
            .set_point(&mut inst, t, x)
            .and_then(|_| inst.call("fmi2GetEventIndicators", |c| c.get_event_indicators(z)).map(|_| ()));
        self.keep(r, z);
    }

    fn take_error(&self) -> Result<(), SimError> {
        match self.error.borrow_mut().take() {
            Some(e) => Err(e.into()),
            None => Ok(()),
        }
    }
}

/// How an integration segment ended.
enum SegmentEnd {
    /// Reached the segment's stop time (a time event, an input breakpoint or the end).
    Stop,
    /// An event indicator crossed zero, or the FMU asked for event mode after a step.
    Event,
    /// The FMU asked to terminate.
    Terminate,
}

/// Progress shared by the segments of one run.
struct Progress {
    t: f64,
    x: Vec<f64>,
    next_output: usize,
    steps: u64,
}

pub(super) fn run(inst: &mut Instance, plan: &Plan) -> Result<SimResult, SimError> {
    initialize(inst, plan)?;
    let md = inst.description();
    let nx = md.states().len();
    let nz = md.number_of_event_indicators;
    let step_event_check = !md.model_exchange.as_ref().is_some_and(|m| m.completed_integrator_step_not_needed);
    let mut rec = Recorder::new(plan);
    let model = Model {
        inst: RefCell::new(inst),
        plan,
        error: RefCell::new(None),
        rhs_evaluations: Cell::new(0),
        segment_end: Cell::new(f64::INFINITY),
        nx,
        nz,
    };

    let mut info = event_iteration(&model, plan.start)?;
    let mut p = Progress { t: plan.start, x: vec![0.0; nx], next_output: 0, steps: 0 };
    let mut nominals = vec![1.0; nx];
    {
        let mut inst = model.inst.borrow_mut();
        inst.call("fmi2EnterContinuousTimeMode", |c| c.enter_continuous_time_mode())?;
        if nx > 0 {
            inst.call("fmi2GetContinuousStates", |c| c.get_continuous_states(&mut p.x))?;
            inst.call("fmi2GetNominalsOfContinuousStates", |c| c.get_nominals_of_continuous_states(&mut nominals))?;
        }
    }
    check_finite(md_state_names(&model), &p.x, p.t)?;
    record_due(&model, &mut rec, &mut p, plan.start, None)?;

    let held = plan.held_columns();
    let mut terminated = false;
    while p.t < plan.stop && info.terminate_simulation == 0 {
        let mut stop = plan.stop;
        if info.next_event_time_defined != 0 && info.next_event_time > p.t {
            stop = stop.min(info.next_event_time);
        }
        if let Some(table) = &plan.inputs
            && let Some(b) = table.next_breakpoint(p.t, &held)
        {
            stop = stop.min(b);
        }
        model.segment_end.set(stop);
        let end = if nx == 0 {
            jump_without_states(&model, &mut rec, &mut p, stop)?
        } else {
            integrate(&model, &mut rec, &mut p, stop, &nominals, step_event_check)?
        };
        model.take_error()?;
        match end {
            SegmentEnd::Terminate => {
                terminated = true;
                break;
            }
            SegmentEnd::Stop if p.t >= plan.stop => break,
            SegmentEnd::Stop | SegmentEnd::Event => {}
        }
        // Event at p.t: left-limit outputs already recorded; now update the discrete state.
        {
            let mut inst = model.inst.borrow_mut();
            model.set_point(&mut inst, p.t, &p.x)?;
            plan.set_inputs(&mut inst, p.t)?;
            inst.call("fmi2EnterEventMode", |c| c.enter_event_mode())?;
        }
        rec.event_times.push(p.t);
        info = event_iteration(&model, p.t)?;
        let mut inst = model.inst.borrow_mut();
        inst.call("fmi2EnterContinuousTimeMode", |c| c.enter_continuous_time_mode())?;
        if nx > 0 && info.values_of_continuous_states_changed != 0 {
            inst.call("fmi2GetContinuousStates", |c| c.get_continuous_states(&mut p.x))?;
        }
        if nx > 0 && info.nominals_of_continuous_states_changed != 0 {
            inst.call("fmi2GetNominalsOfContinuousStates", |c| c.get_nominals_of_continuous_states(&mut nominals))?;
        }
        drop(inst);
        check_finite(md_state_names(&model), &p.x, p.t)?;
    }
    if info.terminate_simulation != 0 && p.t < plan.stop {
        terminated = true;
    }
    let evals = model.rhs_evaluations.get();
    Ok(rec.finish(p.steps, evals, terminated))
}

fn md_state_names(model: &Model) -> Vec<String> {
    model.inst.borrow().description().states().iter().map(|(s, _)| s.name.clone()).collect()
}

fn check_finite(names: Vec<String>, x: &[f64], t: f64) -> Result<(), SimError> {
    match x.iter().position(|v| !v.is_finite()) {
        Some(i) => {
            Err(SimError::NonFinite { time: t, variable: names.get(i).cloned().unwrap_or_default(), value: x[i] })
        }
        None => Ok(()),
    }
}

/// Calls `fmi2NewDiscreteStates` until no new discrete states are needed (at most 1000 times).
fn event_iteration(model: &Model, t: f64) -> Result<EventInfo, SimError> {
    let mut inst = model.inst.borrow_mut();
    let mut merged = EventInfo::default();
    for _ in 0..1000 {
        let mut info = EventInfo::default();
        inst.call("fmi2NewDiscreteStates", |c| c.new_discrete_states(&mut info))?;
        merged.values_of_continuous_states_changed |= info.values_of_continuous_states_changed;
        merged.nominals_of_continuous_states_changed |= info.nominals_of_continuous_states_changed;
        merged.terminate_simulation = info.terminate_simulation;
        merged.next_event_time_defined = info.next_event_time_defined;
        merged.next_event_time = info.next_event_time;
        if info.terminate_simulation != 0 || info.new_discrete_states_needed == 0 {
            return Ok(merged);
        }
    }
    Err(SimError::Solver { time: t, message: "event iteration did not converge in 1000 iterations".into() })
}

/// Records every output time in (last recorded, `upto`] using `state_at` for the states there.
fn record_due(
    model: &Model,
    rec: &mut Recorder,
    p: &mut Progress,
    upto: f64,
    state_at: Option<&dyn Fn(f64) -> Result<Vec<f64>, SimError>>,
) -> Result<(), SimError> {
    let grid = &model.plan.grid;
    while p.next_output < grid.len() && grid[p.next_output] <= upto {
        let tg = grid[p.next_output];
        let x = match state_at {
            Some(f) => f(tg)?,
            None => p.x.clone(),
        };
        let mut inst = model.inst.borrow_mut();
        model.set_point(&mut inst, tg, &x)?;
        rec.record(&mut inst, model.plan, tg)?;
        p.next_output += 1;
    }
    Ok(())
}

/// No continuous states: time advances straight to `stop`, recording outputs on the way.
fn jump_without_states(model: &Model, rec: &mut Recorder, p: &mut Progress, stop: f64) -> Result<SegmentEnd, SimError> {
    record_due(model, rec, p, stop, None)?;
    p.t = stop;
    Ok(SegmentEnd::Stop)
}

/// Integrates from `p.t` to `stop` (or the first event), recording outputs on the way.
fn integrate(
    model: &Model,
    rec: &mut Recorder,
    p: &mut Progress,
    stop: f64,
    nominals: &[f64],
    step_event_check: bool,
) -> Result<SegmentEnd, SimError> {
    let plan = model.plan;
    let atol: Vec<f64> = nominals.iter().map(|n| plan.tolerance * n.abs().max(1e-10)).collect();
    let x0 = p.x.clone();
    let problem = OdeBuilder::<NalgebraMat<f64>>::new()
        .t0(p.t)
        .rtol(plan.tolerance)
        .atol(atol)
        .rhs_implicit(|x, _p, t, y| model.rhs(x, t, y), |x, _p, t, v, y| model.jac_vec(x, t, v, y))
        .init(move |_p, _t, y| y.copy_from_slice(&x0), model.nx)
        .root(|x, _p, t, y| model.indicators(x, t, y), model.nz.max(1))
        .build()
        .map_err(|e| SimError::Solver { time: p.t, message: e.to_string() })?;
    let start_error = |e: diffsol::DiffsolError| {
        model.take_error().err().unwrap_or(SimError::Solver { time: p.t, message: e.to_string() })
    };
    match plan.solver {
        Solver::Bdf => {
            drive(problem.bdf::<NalgebraLU<f64>>().map_err(start_error)?, model, rec, p, stop, step_event_check)
        }
        Solver::Esdirk34 => {
            drive(problem.esdirk34::<NalgebraLU<f64>>().map_err(start_error)?, model, rec, p, stop, step_event_check)
        }
        Solver::TrBdf2 => {
            drive(problem.tr_bdf2::<NalgebraLU<f64>>().map_err(start_error)?, model, rec, p, stop, step_event_check)
        }
        Solver::Tsit45 => drive(problem.tsit45().map_err(start_error)?, model, rec, p, stop, step_event_check),
    }
}

fn drive<'a, Eqn, S>(
    mut solver: S,
    model: &Model,
    rec: &mut Recorder,
    p: &mut Progress,
    stop: f64,
    step_event_check: bool,
) -> Result<SegmentEnd, SimError>
where
    Eqn: OdeEquations<T = f64> + 'a,
    S: OdeSolverMethod<'a, Eqn>,
{
    let plan = model.plan;
    let fail = |e: diffsol::DiffsolError, t: f64| {
        model.take_error().err().unwrap_or(SimError::Solver { time: t, message: e.to_string() })
    };
    let mut sub_stop = next_sub_stop(p.t, stop, plan.max_step);
    solver.set_stop_time(sub_stop).map_err(|e| fail(e, p.t))?;
    loop {
        p.steps += 1;
        plan.check_budget(p.steps, p.t)?;
        let reason = solver.step().map_err(|e| fail(e, p.t))?;
        model.take_error()?;
        let t_now = solver.state().t;
        // Output times are never past the solver's time, except by float noise at a stop time
        // (diffsol stops within a round-off of it).
        let interp = |t: f64| -> Result<Vec<f64>, SimError> {
            solver
                .interpolate(t.min(t_now))
                .map(|v| v.clone_as_vec())
                .map_err(|e| SimError::Solver { time: t, message: e.to_string() })
        };
        match reason {
            OdeSolverStopReason::InternalTimestep => {
                record_due(model, rec, p, t_now, Some(&interp))?;
                p.t = t_now;
                p.x = solver.state().y.clone_as_vec();
                check_finite(md_state_names(model), &p.x, p.t)?;
                if step_event_check {
                    let mut inst = model.inst.borrow_mut();
                    model.set_point(&mut inst, p.t, &p.x)?;
                    let mut out = (crate::fmu::Status::Ok, false, false);
                    inst.call("fmi2CompletedIntegratorStep", |c| {
                        out = c.completed_integrator_step();
                        out.0
                    })?;
                    if out.2 {
                        return Ok(SegmentEnd::Terminate);
                    }
                    if out.1 {
                        return Ok(SegmentEnd::Event);
                    }
                }
            }
            OdeSolverStopReason::RootFound(t_root, _) => {
                record_due(model, rec, p, t_root, Some(&interp))?;
                solver.state_mut_back(t_root).map_err(|e| fail(e, t_root))?;
                p.t = t_root;
                p.x = solver.state().y.clone_as_vec();
                check_finite(md_state_names(model), &p.x, p.t)?;
                return Ok(SegmentEnd::Event);
            }
            OdeSolverStopReason::TstopReached => {
                record_due(model, rec, p, sub_stop, Some(&interp))?;
                p.t = sub_stop;
                p.x = solver.state().y.clone_as_vec();
                check_finite(md_state_names(model), &p.x, p.t)?;
                if sub_stop >= stop {
                    return Ok(SegmentEnd::Stop);
                }
                sub_stop = next_sub_stop(p.t, stop, plan.max_step);
                solver.set_stop_time(sub_stop).map_err(|e| fail(e, p.t))?;
            }
        }
    }
}

fn next_sub_stop(t: f64, stop: f64, max_step: Option<f64>) -> f64 {
    match max_step {
        Some(h) if t + h < stop => t + h,
        _ => stop,
    }
}
