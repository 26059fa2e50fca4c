//! `fmucal simulate`: one simulation from the command line, results as CSV (file or stdout).

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, Result, bail};
use fmucal_shared::fmu::{Fmu, Interface};
use fmucal_shared::sim::{self, OutputTimes, SimSpec, Solver, csv_io};

#[derive(clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// The FMU: a path, or the name of a built-in example (see `fmucal examples`).
    model: String,
    /// Interface: me (Model Exchange) or cs (Co-Simulation). Default: me if offered.
    #[arg(long, value_parser = parse_interface)]
    interface: Option<Interface>,
    /// Start time. Default: the FMU's DefaultExperiment, else 0.
    #[arg(long)]
    start_time: Option<f64>,
    /// Stop time. Default: the FMU's DefaultExperiment, else start + 1.
    #[arg(long)]
    stop_time: Option<f64>,
    /// Output interval. Default: DefaultExperiment stepSize, else (stop - start) / 500.
    #[arg(long, conflicts_with = "output_times")]
    output_interval: Option<f64>,
    /// CSV file whose first column lists the output times.
    #[arg(long)]
    output_times: Option<PathBuf>,
    /// Set a parameter or start value, NAME=VALUE (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    set: Vec<String>,
    /// CSV file of input signals: a `time` column, then one column per input variable.
    #[arg(long)]
    input: Option<PathBuf>,
    /// Variable to record (repeatable). Default: all outputs, or all states if none.
    #[arg(long = "output", value_name = "NAME")]
    outputs: Vec<String>,
    /// Relative tolerance. Default: DefaultExperiment tolerance, else 1e-6.
    #[arg(long)]
    tolerance: Option<f64>,
    /// Model Exchange integrator: bdf (default), esdirk34, tr-bdf2 or tsit45.
    #[arg(long, default_value = "bdf")]
    solver: Solver,
    /// Largest step: the integrator's (ME; default (stop - start) / 50, as FMPy) or fmi2DoStep's
    /// (CS; default none: one step per output interval).
    #[arg(long)]
    max_step: Option<f64>,
    /// Give up after this many seconds of wall time.
    #[arg(long)]
    timeout: Option<f64>,
    /// Output CSV file. Default: standard output.
    #[arg(short = 'o', long = "out")]
    out: Option<PathBuf>,
}

fn parse_interface(s: &str) -> Result<Interface, String> {
    match s {
        "me" => Ok(Interface::ModelExchange),
        "cs" => Ok(Interface::CoSimulation),
        _ => Err(format!("{s:?} is not an interface (expected me or cs)")),
    }
}

pub fn run(args: Args) -> Result<()> {
    let path = super::model_arg::resolve(&args.model)?;
    let parameters = args
        .set
        .iter()
        .map(|kv| match kv.split_once('=') {
            Some((k, v)) if !k.trim().is_empty() => Ok((k.trim().to_owned(), v.trim().to_owned())),
            _ => bail!("--set {kv:?} is not of the form NAME=VALUE"),
        })
        .collect::<Result<Vec<_>>>()?;
    let output_times = match (&args.output_times, args.output_interval) {
        (Some(file), _) => Some(OutputTimes::Times(csv_io::read_times(file)?)),
        (None, Some(dt)) => Some(OutputTimes::Interval(dt)),
        (None, None) => None,
    };
    let inputs = args.input.as_deref().map(csv_io::read_table).transpose()?;
    let timeout = match args.timeout {
        Some(s) if s > 0.0 && s.is_finite() => Some(Duration::from_secs_f64(s)),
        Some(s) => bail!("--timeout {s} must be a positive number of seconds"),
        None => None,
    };
    let spec = SimSpec {
        interface: args.interface,
        start_time: args.start_time,
        stop_time: args.stop_time,
        output_times,
        parameters,
        inputs,
        outputs: args.outputs,
        tolerance: args.tolerance,
        solver: args.solver,
        max_step: args.max_step,
        max_steps: None,
        timeout,
        port_terms: vec![],
        state_terms: vec![],
    };
    let fmu = Fmu::load(&path).with_context(|| format!("cannot load {}", path.display()))?;
    let result = sim::simulate(&fmu, &spec)?;
    if result.terminated_early {
        tracing::warn!(
            time = result.time.last().copied().unwrap_or_default(),
            "the FMU terminated the simulation early"
        );
    }
    match &args.out {
        Some(out) => {
            let file = std::fs::File::create(out).with_context(|| format!("cannot create {}", out.display()))?;
            csv_io::write_result(&result, std::io::BufWriter::new(file), out)?;
            eprintln!(
                "wrote {} rows x {} variables to {} ({} steps, {} events)",
                result.time.len(),
                result.names.len(),
                out.display(),
                result.stats.steps,
                result.stats.events
            );
        }
        None => csv_io::write_result(&result, std::io::stdout().lock(), std::path::Path::new("<stdout>"))?,
    }
    Ok(())
}
