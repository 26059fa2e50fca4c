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
//! Within a segment no step is longer than the plan's maximum step (default (stop − start)/50,
//! as FMPy; like CVODE's, a cap on the step size, not a grid of stops) and none steps past a
//! sample of a continuous input in a model with event indicators: an input can move an event
//! indicator while the states stand still (a body stuck by stiction while the force on it
//! grows), and a step that spans the whole excursion would see no sign change. The samples are
//! sub-stops the solver lands on; a time within round-off of the next stop is that stop. (A
//! model without event indicators steps over samples: it has no event to miss, and each sample
//! of a piecewise-linear input is a kink that would cost BDF several steps.) Events count
//! against the step budget along with the steps.
//!
//! Every completed step is reported with `fmi2CompletedIntegratorStep`: one that ends at a stop
//! time or at a root too. A model without states but with event indicators is integrated on a
//! stand-in state with derivative 0 (never shown to the FMU), so the roots are still found.
//!
//! The port and state terms of effects with kinks (a dead zone's edges) add event indicators
//! of their own after the FMU's: the integrator stops at a kink as at any state event. State terms
//! ([`super::spec::StateTerm`]) are added to the derivatives `fmi2GetDerivatives` returns, so
//! the FMU never sees them: an event indicator the FMU computes from its own derivative (a
//! stick–slip check on the acceleration, say) does not see the term.
//!
//! At each event the FMU enters Event Mode before the inputs are set to their values after the
//! event (discrete inputs may change only in Event Mode, FMI 2.0.4 section 3.2.3), then goes
//! through `fmi2NewDiscreteStates` until no new discrete states are needed; if states changed
//! the integrator restarts from the new states.
//! Outputs at the requested times come from diffsol's dense output, pushed into the FMU before
//! reading. The Jacobian the implicit methods need is a forward finite difference of
//! `fmi2GetDerivatives`.

use std::cell::{Cell, RefCell};

use diffsol::{NalgebraLU, NalgebraMat, OdeBuilder, OdeEquations, OdeSolverMethod, OdeSolverStopReason, Vector};

use super::inputs::Side;
use super::plan::Plan;
use super::spec::{SimError, SimResult, Solver};
use super::{Recorder, initialize, same_instant};
use crate::fmu::ffi::EventInfo;
use crate::fmu::{FmuError, Instance};
use crate::series::TimeSeries;

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
    /// The FMU's event indicators, then the port and state terms' ([`Plan::term_indicators`]):
    /// `nz` in all.
    fmu_nz: usize,
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

    /// Pushes time, continuous inputs and states into the FMU, then the port terms (which
    /// read the states). Inside a segment the inputs at the segment's end are its left limit:
    /// a jump there belongs to the next segment.
    fn set_point(&self, inst: &mut Instance, t: f64, x: &[f64]) -> Result<(), FmuError> {
        inst.set_error_time(t);
        inst.call("fmi2SetTime", |c| c.set_time(t))?;
        let side = if t >= self.segment_end.get() { Side::Left } else { Side::Right };
        self.plan.set_inputs_from(inst, t, side, true)?;
        if !x.is_empty() {
            inst.call("fmi2SetContinuousStates", |c| c.set_continuous_states(x))?;
        }
        self.plan.apply_port_terms(inst, t, side)
    }

    fn rhs(&self, x: &[f64], t: f64, dx: &mut [f64]) {
        if self.failed() {
            dx.fill(f64::NAN);
            return;
        }
        if self.nx == 0 {
            // The stand-in state of a model without states (see `integrate`) stands still.
            dx.fill(0.0);
            return;
        }
        self.rhs_evaluations.set(self.rhs_evaluations.get() + 1);
        let mut inst = self.inst.borrow_mut();
        let r = self
            .set_point(&mut inst, t, x)
            .and_then(|_| inst.call("fmi2GetDerivatives", |c| c.get_derivatives(dx)).map(|_| ()));
        if r.is_ok() {
            self.plan.add_state_terms(x, dx);
        }
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
        let (fmu, terms) = z.split_at_mut(self.fmu_nz);
        let r = self
            .set_point(&mut inst, t, &x[..self.nx])
            .and_then(|_| {
                if fmu.is_empty() {
                    return Ok(());
                }
                inst.call("fmi2GetEventIndicators", |c| c.get_event_indicators(fmu)).map(|_| ())
            })
            .and_then(|_| self.plan.term_indicators(&mut inst, terms));
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
    let mut rec = Recorder::new(plan);
    let model = Model::new(inst, plan);
    let (mut run, mut p) = start(&model, &mut rec, plan.start)?;
    let terminated = advance(&model, &mut rec, &mut p, &mut run, plan.stop)?;
    let evals = model.rhs_evaluations.get();
    Ok(rec.finish(p.steps, evals, terminated))
}

impl<'a> Model<'a> {
    fn new(inst: &'a mut Instance, plan: &'a Plan) -> Self {
        let md = inst.description();
        let nx = md.states().len();
        let fmu_nz = md.number_of_event_indicators;
        Model {
            nx,
            fmu_nz,
            nz: fmu_nz + plan.term_indicator_count(),
            inst: RefCell::new(inst),
            plan,
            error: RefCell::new(None),
            rhs_evaluations: Cell::new(0),
            segment_end: Cell::new(f64::INFINITY),
        }
    }
}

/// What carries over from one stretch of integration to the next: the last event update and
/// the states' nominal values.
struct Carry {
    info: EventInfo,
    nominals: Vec<f64>,
    step_event_check: bool,
}

/// After initialisation at `t0`: the first event update, Continuous-Time Mode, the states and
/// their nominals, and the outputs due at `t0`.
fn start(model: &Model, rec: &mut Recorder, t0: f64) -> Result<(Carry, Progress), SimError> {
    let nx = model.nx;
    let info = event_iteration(model, t0)?;
    let mut p = Progress { t: t0, x: vec![0.0; nx], next_output: 0, steps: 0 };
    let mut nominals = vec![1.0; nx];
    let step_event_check;
    {
        let mut inst = model.inst.borrow_mut();
        step_event_check =
            !inst.description().model_exchange.as_ref().is_some_and(|m| m.completed_integrator_step_not_needed);
        inst.call("fmi2EnterContinuousTimeMode", |c| c.enter_continuous_time_mode())?;
        if nx > 0 {
            inst.call("fmi2GetContinuousStates", |c| c.get_continuous_states(&mut p.x))?;
            inst.call("fmi2GetNominalsOfContinuousStates", |c| c.get_nominals_of_continuous_states(&mut nominals))?;
        }
    }
    check_finite(model, &p.x, p.t)?;
    record_due(model, rec, &mut p, t0, None)?;
    Ok((Carry { info, nominals, step_event_check }, p))
}

/// Integrates from `p.t` to `until` through every event on the way, recording the outputs due.
/// Returns whether the FMU asked to terminate before `until`.
fn advance(model: &Model, rec: &mut Recorder, p: &mut Progress, run: &mut Carry, until: f64) -> Result<bool, SimError> {
    let plan = model.plan;
    let (nx, nz) = (model.nx, model.nz);
    let held = plan.held_columns();
    let mut terminated = false;
    while p.t < until && run.info.terminate_simulation == 0 {
        // Events count against the step budget too: a model that only jumps from event to event
        // (or a period driven towards zero) must still stop.
        plan.check_budget(p.steps + rec.event_times.len() as u64, p.t)?;
        let mut stop = until;
        if run.info.next_event_time_defined != 0 && run.info.next_event_time > p.t {
            stop = stop.min(run.info.next_event_time);
        }
        if let Some(table) = &plan.inputs
            && let Some(b) = table.next_breakpoint(p.t, &held)
        {
            stop = stop.min(b);
        }
        model.segment_end.set(stop);
        // Without states and event indicators nothing happens between events; without states
        // but with indicators the integrator still runs, on a stand-in state, to find roots.
        let end = if (nx == 0 && nz == 0) || same_instant(p.t, stop) {
            jump_without_states(model, rec, p, stop)?
        } else {
            integrate(model, rec, p, stop, &run.nominals, run.step_event_check)?
        };
        model.take_error()?;
        match end {
            SegmentEnd::Terminate => {
                terminated = p.t < until && !same_instant(p.t, until);
                break;
            }
            SegmentEnd::Stop if p.t >= until => break,
            SegmentEnd::Stop | SegmentEnd::Event => {}
        }
        // Event at p.t: left-limit outputs already recorded; now update the discrete state.
        {
            let mut inst = model.inst.borrow_mut();
            model.set_point(&mut inst, p.t, &p.x)?;
            inst.call("fmi2EnterEventMode", |c| c.enter_event_mode())?;
            plan.set_inputs(&mut inst, p.t)?;
            plan.apply_port_terms(&mut inst, p.t, Side::Right)?;
        }
        rec.event_times.push(p.t);
        run.info = event_iteration(model, p.t)?;
        let mut inst = model.inst.borrow_mut();
        inst.call("fmi2EnterContinuousTimeMode", |c| c.enter_continuous_time_mode())?;
        if nx > 0 && run.info.values_of_continuous_states_changed != 0 {
            inst.call("fmi2GetContinuousStates", |c| c.get_continuous_states(&mut p.x))?;
        }
        if nx > 0 && run.info.nominals_of_continuous_states_changed != 0 {
            inst.call("fmi2GetNominalsOfContinuousStates", |c| c.get_nominals_of_continuous_states(&mut run.nominals))?;
        }
        drop(inst);
        check_finite(model, &p.x, p.t)?;
    }
    if run.info.terminate_simulation != 0 && p.t < until {
        terminated = true;
    }
    Ok(terminated)
}

/// Model Exchange integration in stretches, for a Co-Simulation interface over a Model
/// Exchange FMU (`fmucal export`): [`Stepper::start`] once the instance is initialised, then
/// [`Stepper::advance`] to each communication point, with the inputs the caller set on the
/// instance held in between. Between calls the instance stands at the reached time and states,
/// with the port terms applied, so its outputs can be read.
pub struct Stepper {
    carry: Carry,
    progress: Progress,
    terminated: bool,
}

impl Stepper {
    /// Starts at `plan.start` on an instance that has just left Initialization Mode.
    ///
    /// # Errors
    /// The FMU's or the event iteration's failure.
    pub fn start(inst: &mut Instance, plan: &Plan) -> Result<Stepper, SimError> {
        let mut rec = Recorder::new(plan);
        let model = Model::new(inst, plan);
        let (carry, progress) = start(&model, &mut rec, plan.start)?;
        Ok(Stepper { carry, progress, terminated: false })
    }

    /// The time reached.
    pub fn time(&self) -> f64 {
        self.progress.t
    }

    /// Whether the FMU asked to terminate.
    pub fn terminated(&self) -> bool {
        self.terminated || self.carry.info.terminate_simulation != 0
    }

    /// Integrates to `until` (`plan` must have no output grid left), then leaves the instance
    /// at the reached point.
    ///
    /// # Errors
    /// As a simulation: the FMU, the integrator or the step budget.
    pub fn advance(&mut self, inst: &mut Instance, plan: &Plan, until: f64) -> Result<(), SimError> {
        let mut rec = Recorder::new(plan);
        // A stepper records nothing: its outputs are read by the caller.
        self.progress.next_output = plan.grid.len();
        let model = Model::new(inst, plan);
        if advance(&model, &mut rec, &mut self.progress, &mut self.carry, until)? {
            self.terminated = true;
        }
        let mut inst = model.inst.borrow_mut();
        model.segment_end.set(f64::INFINITY);
        model.set_point(&mut inst, self.progress.t, &self.progress.x)?;
        Ok(())
    }
}

/// Fails naming the first state that is not finite.
fn check_finite(model: &Model, x: &[f64], t: f64) -> Result<(), SimError> {
    match x.iter().position(|v| !v.is_finite()) {
        Some(i) => {
            let states =
                model.inst.borrow().description().states().iter().map(|(s, _)| s.name.clone()).collect::<Vec<_>>();
            Err(SimError::NonFinite { time: t, variable: states.get(i).cloned().unwrap_or_default(), value: x[i] })
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

/// The integrator's next intermediate stop after `t` within a segment ending at `stop`: the
/// next sample of `samples` (the continuous inputs, in a model with event indicators), else
/// `stop`; one within round-off of `stop` is `stop`.
fn next_sub_stop(samples: Option<&TimeSeries>, t: f64, stop: f64) -> f64 {
    let next = samples.and_then(|table| table.next_sample(t)).map_or(stop, |s| s.min(stop));
    if same_instant(next, stop) { stop } else { next }
}

/// The stop time to give the solver before its next step from `t`, whose size it proposes to be
/// `h`, or `None` if that step needs none. The step may not pass `sub_stop` nor be longer than
/// `max_step`. Near the sub-stop (less than two steps away) the stop is halfway to it, so that
/// no step shrinks by more than half and none is left with a sliver. The solver learns of a stop
/// only this late because diffsol shrinks its step as soon as it knows, rescaling the history
/// that the outputs inside the previous step are interpolated from; a large shrink loses
/// accuracy.
fn stop_for_next_step(t: f64, sub_stop: f64, h: f64, max_step: Option<f64>) -> Option<f64> {
    let h_allowed = max_step.map_or(h, |m| h.min(m));
    let d = sub_stop - t;
    if d <= h_allowed {
        Some(sub_stop)
    } else if d < 2.0 * h_allowed {
        Some(t + 0.5 * d)
    } else if h > h_allowed {
        Some(t + h_allowed)
    } else {
        None
    }
}

/// Asks the solver to stop at `t_stop`. Returns false if the solver is already there (within
/// its own round-off), in which case the stop counts as reached.
fn set_stop<'a, Eqn, S>(solver: &mut S, t_stop: f64) -> Result<bool, diffsol::DiffsolError>
where
    Eqn: OdeEquations<T = f64> + 'a,
    S: OdeSolverMethod<'a, Eqn>,
{
    use diffsol::error::{DiffsolError, OdeSolverError};
    match solver.set_stop_time(t_stop) {
        Ok(()) => Ok(true),
        Err(DiffsolError::OdeSolverError(OdeSolverError::StopTimeAtCurrentTime)) => Ok(false),
        Err(e) => Err(e),
    }
}

/// No continuous states: time advances straight to `stop`, recording outputs on the way.
fn jump_without_states(model: &Model, rec: &mut Recorder, p: &mut Progress, stop: f64) -> Result<SegmentEnd, SimError> {
    record_due(model, rec, p, stop, None)?;
    p.t = stop;
    Ok(SegmentEnd::Stop)
}

/// Tells the FMU that a step ended at `p.t` (`fmi2CompletedIntegratorStep`, after every step,
/// also one that ends at a stop time), unless it declared it does not need to know. Returns how
/// the segment ends if the FMU asks for Event Mode or to terminate.
fn completed_step(model: &Model, p: &Progress, step_event_check: bool) -> Result<Option<SegmentEnd>, SimError> {
    if !step_event_check {
        return Ok(None);
    }
    let mut inst = model.inst.borrow_mut();
    model.set_point(&mut inst, p.t, &p.x)?;
    let mut out = (crate::fmu::Status::Ok, false, false);
    inst.call("fmi2CompletedIntegratorStep", |c| {
        out = c.completed_integrator_step();
        out.0
    })?;
    Ok(if out.2 {
        Some(SegmentEnd::Terminate)
    } else if out.1 {
        Some(SegmentEnd::Event)
    } else {
        None
    })
}

/// Moves the run's progress to the end of a step: time `t`, the FMU's states from the
/// integrator's vector `y`, which must be finite.
fn arrive(model: &Model, p: &mut Progress, t: f64, y: &impl Vector<T = f64>) -> Result<(), SimError> {
    p.t = t;
    p.x = fmu_states(y, model.nx);
    check_finite(model, &p.x, p.t)
}

/// The FMU's states within the integrator's vector (which holds one stand-in state, with
/// derivative 0, for a model without states, so that diffsol can still locate the roots of its
/// event indicators, as FMPy does).
fn fmu_states(y: &impl Vector<T = f64>, nx: usize) -> Vec<f64> {
    let mut x = y.clone_as_vec();
    x.truncate(nx);
    x
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
    let n = model.nx.max(1);
    let atol: Vec<f64> = (0..n).map(|i| plan.tolerance * nominals.get(i).map_or(1.0, |n| n.abs().max(1e-10))).collect();
    let mut x0 = p.x.clone();
    x0.resize(n, 0.0);
    let problem = OdeBuilder::<NalgebraMat<f64>>::new()
        .t0(p.t)
        .rtol(plan.tolerance)
        .atol(atol)
        .rhs_implicit(|x, _p, t, y| model.rhs(x, t, y), |x, _p, t, v, y| model.jac_vec(x, t, v, y))
        .init(move |_p, _t, y| y.copy_from_slice(&x0), n)
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
    // Samples matter to event detection only: a model without event indicators has nothing to
    // miss, and landing on every sample of a piecewise-linear input (a kink in the derivative
    // each time) costs a multistep method several steps per sample.
    let lands_on_samples = model.nz > 0 && plan.input_bindings.iter().any(|b| !b.hold);
    let samples = plan.inputs.as_ref().filter(|_| lands_on_samples);
    let mut sub_stop = next_sub_stop(samples, p.t, stop);
    // The stop time handed to the solver, if any (see `stop_for_next_step`).
    let mut solver_stop: Option<f64> = None;
    loop {
        if solver_stop.is_none() {
            let reached = same_instant(p.t, sub_stop)
                || match stop_for_next_step(p.t, sub_stop, solver.state().h, plan.max_step) {
                    Some(t) => {
                        let set = set_stop(&mut solver, t).map_err(|e| fail(e, p.t))?;
                        if !set && t != sub_stop {
                            // A cap or halfway stop inside the solver's round-off of its time.
                            return Err(SimError::Invalid(format!(
                                "max step {} is below the time resolution at t={} (about {:e})",
                                plan.max_step.unwrap_or(f64::NAN),
                                p.t,
                                100.0 * f64::EPSILON * p.t.abs()
                            )));
                        }
                        solver_stop = set.then_some(t);
                        !set
                    }
                    None => false,
                };
            if reached {
                record_due(model, rec, p, sub_stop, None)?;
                p.t = sub_stop;
                if sub_stop >= stop {
                    return Ok(SegmentEnd::Stop);
                }
                sub_stop = next_sub_stop(samples, sub_stop, stop);
                continue;
            }
        }
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
                .map(|v| fmu_states(&v, model.nx))
                .map_err(|e| SimError::Solver { time: t, message: e.to_string() })
        };
        match reason {
            OdeSolverStopReason::InternalTimestep => {
                record_due(model, rec, p, t_now, Some(&interp))?;
                arrive(model, p, t_now, solver.state().y)?;
                if let Some(end) = completed_step(model, p, step_event_check)? {
                    return Ok(end);
                }
            }
            OdeSolverStopReason::RootFound(t_root, _) => {
                record_due(model, rec, p, t_root, Some(&interp))?;
                solver.state_mut_back(t_root).map_err(|e| fail(e, t_root))?;
                arrive(model, p, t_root, solver.state().y)?;
                // The step is complete up to the root, as FMPy and the standard's loop have it.
                let end = completed_step(model, p, step_event_check)?;
                return Ok(if matches!(end, Some(SegmentEnd::Terminate)) {
                    SegmentEnd::Terminate
                } else {
                    SegmentEnd::Event
                });
            }
            OdeSolverStopReason::TstopReached => {
                let reached = solver_stop.take().unwrap_or(t_now);
                record_due(model, rec, p, reached, Some(&interp))?;
                arrive(model, p, reached, solver.state().y)?;
                if let Some(end) = completed_step(model, p, step_event_check)? {
                    return Ok(end);
                }
                if reached == sub_stop {
                    if sub_stop >= stop {
                        return Ok(SegmentEnd::Stop);
                    }
                    sub_stop = next_sub_stop(samples, sub_stop, stop);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sub_stops_are_continuous_input_samples_then_the_stop() {
        let table = TimeSeries { time: vec![0.0, 0.25, 0.3, 2.0], columns: vec![("u".into(), vec![0.0; 4])] };
        let seen: Vec<f64> =
            std::iter::successors(Some(0.0), |&t| (t < 1.0).then(|| next_sub_stop(Some(&table), t, 1.0)))
                .skip(1)
                .collect();
        assert_eq!(seen, [0.25, 0.3, 1.0]);
        // A sample within round-off of the stop is the stop.
        assert_eq!(next_sub_stop(None, 0.5, 1.0), 1.0);
        let near = TimeSeries { time: vec![0.0, 1.0 - 1e-15], columns: vec![("u".into(), vec![0.0; 2])] };
        assert_eq!(next_sub_stop(Some(&near), 0.5, 1.0), 1.0);
    }

    #[test]
    fn the_solver_hears_of_a_stop_only_before_the_step_that_needs_it() {
        // Far from the sub-stop and within the maximum step: no stop.
        assert_eq!(stop_for_next_step(0.0, 1.0, 0.3, None), None);
        assert_eq!(stop_for_next_step(0.0, 1.0, 0.3, Some(0.4)), None);
        // Within two steps: halfway; within one: the sub-stop.
        assert_eq!(stop_for_next_step(0.0, 1.0, 0.6, None), Some(0.5));
        assert_eq!(stop_for_next_step(0.0, 1.0, 1.5, None), Some(1.0));
        // A proposed step longer than the maximum step is capped, with the same rules near the stop.
        assert_eq!(stop_for_next_step(0.0, 1.0, 0.5, Some(0.1)), Some(0.1));
        assert_eq!(stop_for_next_step(0.0, 1.0, 5.0, Some(0.6)), Some(0.5));
        assert_eq!(stop_for_next_step(0.0, 1.0, 5.0, Some(2.0)), Some(1.0));
    }
}
