//! FMI 2.0 conformance on fixture FMUs that behave as tool-exported ones do, one
//! test per defect found on real exports. Each failed before its fix:
//! - `derivative` attributes on variables that are not states were refused;
//! - a stick-slip breakaway driven by a continuous input was missed by an over-long step, and
//!   a model without states never had its event indicators evaluated;
//! - `fmi2CompletedIntegratorStep` was skipped after steps that ended at a stop time;
//! - held inputs were set in Continuous-Time Mode, which FMUs answer with `fmi2Error`;
//! - `max_step` stops accumulated round-off and failed just before the stop time;
//! - a Co-Simulation FMU terminating mid-step lost its last values;
//! - a Model Exchange FMU was handed a tolerance it warns about, and repeated messages flooded
//!   the log;
//! - `inspect` refused an FMU without a binary for this platform.
//!
//! References are analytic (the stick-slip breakaway time, the integral of piecewise inputs,
//! exp(−t)) or fmucal itself at a 1000 times smaller maximum step; the comparisons with FMPy
//! are in `fmpy_crosscheck.rs`.

mod common;

use std::io::Write;
use std::path::Path;
use std::process::Command;
use std::sync::{Arc, Mutex};

use fmucal_shared::fmu::{Fmu, Interface};
use fmucal_shared::sim::{InputTable, OutputTimes, SimSpec, Simulator, Solver, simulate};

/// The FMU at `path`, unpacked into a temporary folder that lasts as long as the returned
/// handle.
fn unpacked(path: &Path) -> (tempfile::TempDir, Fmu) {
    let tmp = tempfile::tempdir().unwrap();
    let fmu = common::load(path, tmp.path());
    (tmp, fmu)
}

fn spec(interface: Interface, stop: f64, dt: f64) -> SimSpec {
    SimSpec {
        interface: Some(interface),
        stop_time: Some(stop),
        output_times: Some(OutputTimes::Interval(dt)),
        tolerance: Some(1e-8),
        ..Default::default()
    }
}

#[test]
fn derivative_attributes_outside_model_structure_load_and_simulate_as_the_plain_model() {
    let (tmp, tooly) = unpacked(&fmucal_models::Fixture::DerivativeAttributes.path());
    let states: Vec<&str> = tooly.description.states().iter().map(|(s, _)| s.name.as_str()).collect();
    assert_eq!(states, ["h", "v"]);
    let plain = common::load_example("bouncing-ball", tmp.path());
    for interface in [Interface::ModelExchange, Interface::CoSimulation] {
        let a = simulate(&tooly, &spec(interface, 3.0, 0.01)).unwrap();
        let b = simulate(&plain, &spec(interface, 3.0, 0.01)).unwrap();
        assert_eq!(a.columns, b.columns, "{interface}");
    }
}

/// A force pulse that exceeds the stiction force Fs = 1 only between 8.154 s and 8.246 s,
/// while the default maximum step over 20 s is 0.4 s: only the input's samples show it.
fn pulse() -> InputTable {
    common::table(vec![0.0, 8.0, 8.2, 8.4, 20.0], vec![("F", vec![0.0, 0.0, 1.3, 0.0, 0.0])])
}

#[test]
fn stick_slip_breaks_away_when_the_input_force_exceeds_stiction() {
    let (_tmp, fmu) = unpacked(&fmucal_models::Fixture::StickSlip.path());
    let run = simulate(&fmu, &SimSpec { inputs: Some(pulse()), ..spec(Interface::ModelExchange, 20.0, 0.01) }).unwrap();
    // The body at x = 0 sticks until F = 6.5 (t − 8) reaches Fs = 1.
    let breakaway = 8.0 + 1.0 / 6.5;
    let first = run.event_times.first().copied().unwrap_or(f64::NAN);
    assert!((first - breakaway).abs() < 1e-9, "first event at {first}, breakaway at {breakaway}");
    let x = run.column("x").unwrap();
    assert!(x.last().unwrap() > &1e-4, "the body never moved: x(20) = {}", x.last().unwrap());
    assert_eq!(*run.time.last().unwrap(), 20.0);
}

#[test]
fn a_model_without_states_finds_the_events_its_input_causes() {
    let (_tmp, fmu) = unpacked(&fmucal_models::Fixture::Threshold.path());
    // u rises from 0 to 2 over [1, 1.205] and falls back by 1.41: it crosses 1 at 1.1025 and
    // 1.3075, between output points.
    let u = common::table(vec![0.0, 1.0, 1.205, 1.41, 3.0], vec![("u", vec![0.0, 0.0, 2.0, 0.0, 0.0])]);
    let run = simulate(&fmu, &SimSpec { inputs: Some(u), ..spec(Interface::ModelExchange, 3.0, 0.01) }).unwrap();
    assert_eq!(run.event_times.len(), 2, "{:?}", run.event_times);
    for (got, want) in run.event_times.iter().zip([1.1025, 1.3075]) {
        assert!((got - want).abs() < 1e-9, "switch at {got}, want {want}");
    }
    let (above, crossings) = (run.column("above").unwrap(), run.column("crossings").unwrap());
    for (i, &t) in run.time.iter().enumerate() {
        let inside = t > 1.1025 && t < 1.3075;
        assert_eq!(above[i], if inside { 1.0 } else { 0.0 }, "above at {t}");
    }
    assert_eq!(*crossings.last().unwrap(), 2.0);
}

#[test]
fn every_completed_step_is_reported_to_the_fmu() {
    let (_tmp, fmu) = unpacked(&fmucal_models::Fixture::InputKinds.path());
    let s = SimSpec {
        inputs: Some(common::every_kind_of_input()),
        outputs: vec!["completedSteps".into()],
        ..spec(Interface::ModelExchange, 4.0, 0.01)
    };
    let run = simulate(&fmu, &s).unwrap();
    // Most steps end at a sub-stop here (input samples, the maximum step). The last row is
    // read before the last step is reported.
    let reported = *run.column("completedSteps").unwrap().last().unwrap();
    assert_eq!(reported, (run.stats.steps - 1) as f64, "{} steps", run.stats.steps);
}

#[test]
fn stick_slip_trajectory_matches_a_run_at_a_thousandth_of_the_step() {
    let (_tmp, fmu) = unpacked(&fmucal_models::Fixture::StickSlip.path());
    let base = SimSpec {
        inputs: Some(common::sine_force()),
        outputs: vec!["x".into(), "v".into(), "stuck".into()],
        ..spec(Interface::ModelExchange, 20.0, 0.01)
    };
    let ours = simulate(&fmu, &base).unwrap();
    let reference = simulate(&fmu, &SimSpec { max_step: Some(4e-4), ..base.clone() }).unwrap();
    assert!(ours.event_times.len() >= 6, "expected several stick/slip transitions: {:?}", ours.event_times);
    for name in ["x", "v"] {
        let d = common::rel_max_diff(ours.column(name).unwrap(), reference.column(name).unwrap());
        assert!(d < 1e-5, "{name}: default step and 4e-4 differ by {d:e}");
    }
    let stuck = ours.column("stuck").unwrap();
    assert!(stuck.contains(&0.0) && stuck.contains(&1.0), "no stick and slip phases: {stuck:?}");
}

#[test]
fn model_exchange_steps_are_at_most_a_fiftieth_of_the_span_by_default() {
    let (_tmp, fmu) = unpacked(&common::example("decay"));
    // x' = 0 with an explicit solver: nothing limits the step but the maximum step, so the
    // default needs at least one step per 1/50 of the span, and a maximum step as long as the
    // span needs a handful.
    let frozen = SimSpec {
        parameters: vec![("enabled".into(), "false".into())],
        solver: Solver::Tsit45,
        ..spec(Interface::ModelExchange, 1000.0, 500.0)
    };
    let run = simulate(&fmu, &frozen).unwrap();
    assert!(run.stats.steps >= 50, "{} steps by default", run.stats.steps);
    let unlimited = simulate(&fmu, &SimSpec { max_step: Some(1000.0), ..frozen }).unwrap();
    assert!(unlimited.stats.steps < 50, "{} steps with max step 1000", unlimited.stats.steps);
    assert_eq!(run.column("x").unwrap(), [1.0, 1.0, 1.0]);
}

/// x(t) = ∫ uc + ud + n + b: uc integrated exactly as a piecewise-linear signal, the others
/// as right-continuous steps.
fn integral_of_inputs(table: &InputTable, t: f64) -> f64 {
    let (time, col) = (&table.time, |k: usize| &table.columns[k].1);
    let mut x = 0.0;
    for i in 0..time.len() - 1 {
        let (a, b) = (time[i], time[i + 1].min(t));
        if b <= a {
            break;
        }
        let slope = (col(0)[i + 1] - col(0)[i]) / (time[i + 1] - time[i]);
        let uc_a = col(0)[i];
        let uc_b = uc_a + slope * (b - a);
        x += 0.5 * (uc_a + uc_b) * (b - a);
        x += (col(1)[i] + col(2)[i] + col(3)[i]) * (b - a);
    }
    x
}

#[test]
fn held_inputs_are_set_in_event_mode_and_integrate_exactly() {
    let (_tmp, fmu) = unpacked(&fmucal_models::Fixture::InputKinds.path());
    let inputs = common::every_kind_of_input();
    let run = simulate(&fmu, &SimSpec { inputs: Some(inputs.clone()), ..spec(Interface::ModelExchange, 4.0, 0.01) })
        .unwrap_or_else(|e| panic!("{e}"));
    let x = run.column("x").unwrap();
    for (i, &t) in run.time.iter().enumerate() {
        let want = integral_of_inputs(&inputs, t);
        assert!((x[i] - want).abs() < 1e-6, "x({t}) = {} but the integral of the inputs is {want}", x[i]);
        let held = |k: usize| inputs.value(k, t, true);
        assert_eq!(run.column("yd").unwrap()[i], held(1), "yd at {t}");
        assert_eq!(run.column("yn").unwrap()[i], held(2), "yn at {t}");
        assert_eq!(run.column("yb").unwrap()[i], held(3), "yb at {t}");
    }
    // The four held changes are events.
    assert_eq!(run.event_times, [0.7005, 1.5005, 2.2505, 3.0005]);
}

#[test]
fn max_step_runs_reach_the_stop_time_despite_round_off() {
    let (tmp, fmu) = unpacked(&common::example("decay"));
    let mut sim = Simulator::new(&fmu, Some(Interface::ModelExchange)).unwrap();
    let mut cs = Simulator::new(&fmu, Some(Interface::CoSimulation)).unwrap();
    for (stop, h) in [(1.0, 0.1), (3.0, 0.3), (10.0, 0.1), (10.0, 0.01)] {
        for sim in [&mut sim, &mut cs] {
            let run = sim
                .run(&SimSpec { max_step: Some(h), ..spec(sim.interface(), stop, stop / 10.0) })
                .unwrap_or_else(|e| panic!("stop {stop}, max step {h}, {}: {e}", sim.interface()));
            let x = *run.column("x").unwrap().last().unwrap();
            assert!((x - (-stop).exp()).abs() < 1e-7, "x({stop}) = {x}");
            // No step longer than h: CS splits each output interval into whole steps of h.
            let least = (stop / h).round() as u64;
            match sim.interface() {
                Interface::CoSimulation => assert_eq!(run.stats.steps, least, "stop {stop}, h {h}"),
                Interface::ModelExchange => assert!(run.stats.steps >= least, "{} steps", run.stats.steps),
            }
        }
    }
    // The same through the command line, as a user runs it.
    let out = Command::new(env!("CARGO_BIN_EXE_fmucal"))
        .args(["simulate", "example:decay", "--stop-time", "10", "--max-step", "0.01", "-o", "/dev/null"])
        .env("FMUCAL_CACHE_DIR", tmp.path())
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn co_simulation_termination_keeps_the_values_at_the_last_successful_time() {
    let (_tmp, fmu) = unpacked(&common::example("decay"));
    let s = SimSpec {
        parameters: vec![("terminateTime".into(), "0.555".into())],
        ..spec(Interface::CoSimulation, 1.0, 0.1)
    };
    let run = simulate(&fmu, &s).unwrap();
    assert!(run.terminated_early);
    let t_last = *run.time.last().unwrap();
    assert!((t_last - 0.555).abs() < 1e-12, "last row at {t_last}");
    assert_eq!(run.time.len(), 7, "0, 0.1, ..., 0.5 and 0.555: {:?}", run.time);
    let x = *run.column("x").unwrap().last().unwrap();
    assert!((x - (-0.555f64).exp()).abs() < 1e-10, "x(0.555) = {x}");
}

/// A writer for a test subscriber that keeps everything written.
#[derive(Clone, Default)]
struct Captured(Arc<Mutex<Vec<u8>>>);

impl Write for Captured {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Runs `f` with every log line at INFO and above captured; returns the lines.
fn logged(f: impl FnOnce()) -> Vec<String> {
    let captured = Captured::default();
    let writer = captured.clone();
    let subscriber = tracing_subscriber::fmt()
        .with_writer(move || writer.clone())
        .with_ansi(false)
        .with_max_level(tracing::Level::INFO)
        .finish();
    tracing::subscriber::with_default(subscriber, f);
    let text = String::from_utf8(captured.0.lock().unwrap().clone()).unwrap();
    text.lines().map(str::to_owned).collect()
}

#[test]
fn model_exchange_gets_no_tolerance_and_co_simulation_does() {
    let (_tmp, fmu) = unpacked(&fmucal_models::Fixture::InputKinds.path());
    let mut seen = vec![];
    let lines = logged(|| {
        for interface in [Interface::ModelExchange, Interface::CoSimulation] {
            let s = SimSpec { outputs: vec!["experimentTolerance".into()], ..spec(interface, 1.0, 0.5) };
            seen.push(simulate(&fmu, &s).unwrap().column("experimentTolerance").unwrap()[0]);
        }
    });
    assert_eq!(seen, [0.0, 1e-8], "tolerance received by ME and CS");
    assert!(!lines.iter().any(|l| l.contains("tolerance is ignored")), "{lines:#?}");
}

#[test]
fn a_repeated_fmu_message_is_logged_once_per_instance_with_a_count() {
    let (_tmp, fmu) = unpacked(&fmucal_models::Fixture::InputKinds.path());
    let s = SimSpec {
        parameters: vec![("ucMax".into(), "0.5".into())],
        inputs: Some(common::table(vec![0.0, 1.0], vec![("uc", vec![1.0, 1.0])])),
        ..spec(Interface::ModelExchange, 1.0, 0.01)
    };
    let mut evaluations = 0;
    let lines = logged(|| {
        let mut sim = Simulator::new(&fmu, Some(Interface::ModelExchange)).unwrap();
        for _ in 0..3 {
            evaluations += sim.run(&s).unwrap().stats.rhs_evaluations;
        }
    });
    let warned: Vec<&String> = lines.iter().filter(|l| l.contains("outside [-ucMax, ucMax]")).collect();
    assert!(evaluations > 100, "{evaluations} evaluations");
    assert_eq!(warned.len(), 2, "first time, then a count when the instance is freed: {warned:#?}");
    assert!(warned[0].contains("WARN") && !warned[0].contains("repeated"), "{}", warned[0]);
    assert!(warned[1].contains("more times)"), "{}", warned[1]);
}

fn fmucal(args: &[&str], cache: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_fmucal")).args(args).env("FMUCAL_CACHE_DIR", cache).output().unwrap()
}

#[test]
fn inspect_shows_an_fmu_without_a_binary_for_this_platform() {
    let tmp = tempfile::tempdir().unwrap();
    let cache = tmp.path().join("cache");
    let no_linux = common::repack("decay", tmp.path(), "NoLinux.fmu", |name, bytes| {
        (!name.starts_with("binaries/linux64/")).then_some(bytes)
    });
    let mut entries: Vec<_> =
        common::entries(&no_linux).into_iter().filter(|(n, _)| !n.starts_with("binaries/linux64")).collect();
    entries.push(("binaries/linux64/".into(), vec![]));
    let empty_linux = tmp.path().join("EmptyLinux.fmu");
    common::write_zip(&empty_linux, &entries);
    entries.push(("binaries/linux64/README.txt".into(), b"built for another platform".to_vec()));
    let readme_linux = tmp.path().join("ReadmeLinux.fmu");
    common::write_zip(&readme_linux, &entries);
    for fmu in [&no_linux, &empty_linux, &readme_linux] {
        let out = fmucal(&["inspect", fmu.to_str().unwrap()], &cache);
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        assert!(stdout.contains("Decay") && stdout.contains("kickTime"), "{stdout}");
        let binaries = stdout.lines().find(|l| l.starts_with("Binaries")).unwrap_or_default();
        assert!(binaries.contains("(no linux64 binary binaries/linux64/Decay.so"), "{binaries}");
        // Simulating it fails with one line naming the platforms it has.
        let out = fmucal(&["simulate", fmu.to_str().unwrap(), "-o", "/dev/null"], &cache);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1));
        assert!(stderr.contains("platforms present: darwin64,"), "{stderr}");
        // An empty folder counts as absent; one with a file but not the binary is listed.
        let listed_linux = fmu == &readme_linux;
        assert_eq!(binaries.starts_with("Binaries           darwin64, linux64,"), listed_linux, "{binaries}");
    }
    let out = fmucal(&["inspect", "example:decay"], &cache);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.lines().any(|l| l.starts_with("Binaries") && l.ends_with("darwin64, linux64, win32, win64")),
        "{stdout}"
    );
}
