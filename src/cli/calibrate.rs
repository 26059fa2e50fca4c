//! `fmucal calibrate JOB.toml`: checks the job locally, then either starts an in-process
//! coordinator on loopback with a generated token and N worker processes (restarted if they
//! die), or submits to `--coordinator URL`. Follows progress with a bar, then writes
//! `result.json`, `convergence.csv` and `fit.csv` (measured, nominal and optimized outputs) and
//! the plots (`fit`, `error`, `convergence`, as SVG and PNG) to `--out`.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use anyhow::{Context, Result, bail};
use fmucal_proto::auth::AttachToken;
use fmucal_proto::convert::{job_to_proto, result_from_proto};
use fmucal_proto::v1 as pb;
use fmucal_proto::v1::calibration_client::CalibrationClient;
use fmucal_shared::fmu::Fmu;
use fmucal_shared::job::identifiability::Identifiability;
use fmucal_shared::job::result::{ErrorReport, WindowError};
use fmucal_shared::job::{
    CalibrationResult, Evaluator, HistoryPoint, JobSpec, MeasurementTable, PreparedJob, identifiability,
};
use tonic::service::interceptor::InterceptedService;
use tonic::transport::Channel;

#[derive(clap::Args)]
pub struct Args {
    /// The job file (TOML).
    job: PathBuf,
    /// Worker processes for a local run. Default: the job's [workers] count, else the number of cores.
    #[arg(long)]
    workers: Option<usize>,
    /// Output folder for result.json, convergence.csv and fit.csv.
    #[arg(long, default_value = "calibration")]
    out: PathBuf,
    /// Submit to a running coordinator instead of starting one.
    #[arg(long)]
    coordinator: Option<String>,
    /// Token file for --coordinator (else FMUCAL_TOKEN).
    #[arg(long)]
    token_file: Option<PathBuf>,
}

type Client = CalibrationClient<InterceptedService<Channel, AttachToken>>;

/// Resolves `example:NAME` and checks the file exists.
fn model_path(spec: &JobSpec) -> Result<PathBuf> {
    let p = spec.model.path.as_ref().context("the job's [model] needs a path for the CLI")?;
    let text = p.to_string_lossy();
    if let Some(name) = text.strip_prefix("example:") {
        return super::model_arg::example(name)?.with_context(|| format!("no built-in example {name:?}"));
    }
    anyhow::ensure!(p.is_file(), "model file {} does not exist", p.display());
    Ok(p.clone())
}

pub fn run(args: Args) -> Result<()> {
    let mut spec = JobSpec::from_toml_file(&args.job)?;
    spec.validate()?;
    let model = model_path(&spec)?;
    spec.model.path = Some(model.clone());
    let data_path = spec.data.path.clone().context("the job's [data] needs a path for the CLI")?;
    let data = MeasurementTable::read(&data_path, &spec.data.time_column)?;
    // Check everything locally first: bad jobs fail before any process starts.
    let fmu = Arc::new(Fmu::load(&model).with_context(|| format!("cannot load {}", model.display()))?);
    let prepared = Arc::new(PreparedJob::new(&spec, &fmu.description, &fmu.interfaces(), &data)?);
    fmucal_shared::job::optimizer::build(&spec)?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;

    let threads = args
        .workers
        .or(spec.workers.count)
        .unwrap_or_else(|| std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1))
        .max(1);
    let rt = tokio::runtime::Runtime::new()?;
    let (mut result, identified) = rt.block_on(async {
        match &args.coordinator {
            Some(url) => {
                let token = super::token::load(args.token_file.as_deref())?;
                let client = connect(url, token.as_deref()).await?;
                let result = follow(client.clone(), &spec, &data, &model).await?;
                let id = identify(client, &prepared, &result, &data, &model).await;
                Ok::<_, anyhow::Error>((result, id))
            }
            None => run_local(&prepared, &data, &model, threads).await,
        }
    })?;
    match identified {
        Ok(id) => result.identifiability = Some(id),
        Err(e) => tracing::warn!("no identifiability analysis: {e:#}"),
    }

    write_outputs(&args.out, &mut result, &fmu, &prepared, &data)?;
    crate::report::draw_all(&args.out)?;
    println!(
        "termination: {}; f_opt = {:.6e} after {} evaluations in {:.1} s",
        result.termination, result.f_opt, result.evaluations, result.elapsed_s
    );
    for (name, v) in &result.x_opt {
        let se = result.identifiability.as_ref().and_then(|id| {
            let k = id.names.iter().position(|n| n == name)?;
            Some(format!("  (standard error {:.2e})", id.standard_errors[k]))
        });
        println!("  {name} = {v:.6e}{}", se.unwrap_or_default());
    }
    if let Some(e) = &result.errors {
        let v = e.validation.as_ref().map(|v| format!(", validation {:.3}", v.scaled_rms)).unwrap_or_default();
        println!("scaled RMS error (optimized / nominal): calibration {:.3}{v}", e.calibration.scaled_rms);
    }
    if let Some(id) = &result.identifiability
        && id.names.len() > 1
    {
        println!("largest parameter correlation: {:.3}", id.max_abs_correlation());
    }
    eprintln!("wrote {}", args.out.join("result.json").display());
    Ok(())
}

async fn connect(url: &str, token: Option<&str>) -> Result<Client> {
    let attach = AttachToken::new(token).map_err(anyhow::Error::msg)?;
    let endpoint = tonic::transport::Endpoint::from_shared(url.to_owned())?
        .tcp_nodelay(true)
        .connect_timeout(Duration::from_secs(2));
    // A coordinator started a moment ago may not listen yet: retry for a few seconds.
    let mut attempt = 0;
    let channel = loop {
        match endpoint.connect().await {
            Ok(ch) => break ch,
            Err(e) if attempt >= 25 => {
                return Err(anyhow::Error::new(e).context(format!("cannot reach the coordinator at {url}")));
            }
            Err(_) => {
                attempt += 1;
                tokio::time::sleep(Duration::from_millis(200)).await;
            }
        }
    };
    Ok(CalibrationClient::with_interceptor(channel, attach)
        .max_encoding_message_size(fmucal_proto::MAX_MESSAGE_BYTES)
        .max_decoding_message_size(fmucal_proto::MAX_MESSAGE_BYTES))
}

/// Calibrates and then runs the identifiability points, on the same local cluster.
async fn run_local(
    job: &PreparedJob,
    data: &MeasurementTable,
    model: &Path,
    workers: usize,
) -> Result<(CalibrationResult, Result<Identifiability>)> {
    let spec = &job.spec;
    let token = super::token::generate()?;
    let state = tempfile::tempdir()?;
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
    let url = format!("http://{}", listener.local_addr()?);
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    let config = fmucal_coordinator::Config {
        data_dir: state.path().join("coordinator"),
        token: Some(token.clone()),
        timing: Default::default(),
    };
    let server = tokio::spawn(fmucal_coordinator::run(config, listener, async {
        let _ = stop_rx.await;
    }));
    let exe = std::env::current_exe()?;
    let cache = state.path().join("worker-cache");
    let spawn = |k: usize| {
        tokio::process::Command::new(&exe)
            .args(["worker", "--coordinator", &url, "--cache-dir"])
            .arg(&cache)
            .env("FMUCAL_TOKEN", &token)
            .env("HOSTNAME", format!("local{k}"))
            .stdin(std::process::Stdio::null())
            .stdout(std::process::Stdio::null())
            .kill_on_drop(true)
            .spawn()
    };
    let mut children =
        (0..workers).map(&spawn).collect::<std::io::Result<Vec<_>>>().context("cannot start worker processes")?;
    let client = connect(&url, Some(&token)).await?;
    let work = async {
        let result = follow(client.clone(), spec, data, model).await?;
        let id = identify(client, job, &result, data, model).await;
        Ok((result, id))
    };
    tokio::pin!(work);
    // Supervise: a worker that dies (an FMU may crash it) is replaced.
    let mut restarts = 0;
    let result = loop {
        tokio::select! {
            r = &mut work => break r,
            _ = tokio::time::sleep(Duration::from_millis(200)) => {
                for (k, c) in children.iter_mut().enumerate() {
                    if let Ok(Some(status)) = c.try_wait() {
                        restarts += 1;
                        if restarts > 1000 {
                            bail!("workers keep dying ({status}); giving up");
                        }
                        tracing::warn!(worker = k, %status, "worker exited; starting another");
                        *c = spawn(k)?;
                    }
                }
            }
        }
    };
    for c in &mut children {
        let _ = c.start_kill();
    }
    let _ = stop_tx.send(());
    let _ = server.await;
    result
}

/// Uploads the model, submits the job, shows progress, and returns the result.
/// Uploads the model (a no-op if the coordinator has it) and submits the job.
async fn submit(client: &mut Client, spec: &JobSpec, data: &MeasurementTable, model: &Path) -> Result<String> {
    let bytes = std::fs::read(model)?;
    let chunks: Vec<pb::UploadModelRequest> =
        bytes.chunks(fmucal_proto::MODEL_CHUNK_BYTES).map(|c| pb::UploadModelRequest { chunk: c.to_vec() }).collect();
    let model_id =
        client.upload_model(tokio_stream::iter(chunks)).await.context("uploading the model")?.into_inner().model_id;
    Ok(client
        .submit_job(pb::SubmitJobRequest { spec: Some(job_to_proto(spec, data, &model_id)) })
        .await
        .map_err(|s| anyhow::anyhow!("the coordinator rejected the job: {}", s.message()))?
        .into_inner()
        .job_id)
}

/// Standard errors and correlations at the optimum: the finite-difference points run as one
/// batch on the workers (a `points` job), then the statistics are derived here.
async fn identify(
    mut client: Client,
    job: &PreparedJob,
    result: &CalibrationResult,
    data: &MeasurementTable,
    model: &Path,
) -> Result<Identifiability> {
    let x: Vec<f64> = job.parameter_names.iter().map(|n| result.x_opt.get(n).copied().unwrap_or(f64::NAN)).collect();
    let plan = identifiability::difference_points(job, &x);
    let spec = job.spec.evaluating_points(plan.points.clone());
    let job_id = submit(&mut client, &spec, data, model).await?;
    let r = wait_for_end(&mut client, &job_id, |_| {}).await?;
    let evaluated = r.result.map(|r| result_from_proto(r, vec![]).evaluated).unwrap_or_default();
    let residuals = identifiability::residuals_of(&evaluated)?;
    Ok(identifiability::from_residuals(&job.parameter_names, &plan, &residuals)?)
}

/// Follows a job's `WatchJob` stream (one event per completed batch, the first at once),
/// handing each event to `on_event`, until the job has ended; then returns its final state.
async fn wait_for_end(
    client: &mut Client,
    job_id: &str,
    mut on_event: impl FnMut(&pb::WatchJobResponse),
) -> Result<pb::GetJobResponse> {
    let ended = |status: i32| {
        [pb::JobStatus::Succeeded, pb::JobStatus::Failed, pb::JobStatus::Cancelled].iter().any(|s| *s as i32 == status)
    };
    let mut stream = client.watch_job(pb::WatchJobRequest { job_id: job_id.to_owned() }).await?.into_inner();
    // The stream also ends when the coordinator has sent the last event of a finished job.
    while let Some(ev) = stream.message().await? {
        on_event(&ev);
        if ended(ev.status) {
            break;
        }
    }
    Ok(client.get_job(pb::GetJobRequest { job_id: job_id.to_owned() }).await?.into_inner())
}

async fn follow(
    mut client: Client,
    spec: &JobSpec,
    data: &MeasurementTable,
    model: &Path,
) -> Result<CalibrationResult> {
    let job_id = submit(&mut client, spec, data, model).await?;
    let bar = indicatif::ProgressBar::new_spinner();
    bar.set_style(
        indicatif::ProgressStyle::with_template("{spinner} {elapsed_precise} {msg}").expect("valid template"),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    let mut history = vec![];
    let job = wait_for_end(&mut client, &job_id, |ev| {
        bar.set_message(format!(
            "iteration {}  evaluations {}  best f {:.6e}",
            ev.iteration, ev.evaluations, ev.best_f
        ));
        if ev.batch_wall_s > 0.0 {
            history.push(HistoryPoint {
                round: ev.rounds,
                evaluations: ev.evaluations,
                best_f: ev.best_f,
                batch_wall_s: ev.batch_wall_s,
            });
        }
    })
    .await?;
    bar.finish_and_clear();
    if job.status == pb::JobStatus::Failed as i32 {
        bail!("the job failed: {}", job.error);
    }
    let r = job.result.context("the coordinator returned no result")?;
    Ok(result_from_proto(r, history))
}

fn write_outputs(
    out: &Path,
    result: &mut CalibrationResult,
    fmu: &Arc<Fmu>,
    job: &Arc<PreparedJob>,
    data: &MeasurementTable,
) -> Result<()> {
    let spec = &job.spec;
    let (_, x0, _, _) = spec.parameter_vectors();
    let x_opt: Vec<f64> =
        job.parameter_names.iter().map(|n| result.x_opt.get(n).copied().unwrap_or(f64::NAN)).collect();
    // The report spans the validation window too, if the job has one.
    let report_job = match spec.simulation.validation_stop_time {
        Some(stop) => {
            let mut s = spec.clone();
            s.simulation.stop_time = Some(stop);
            Arc::new(PreparedJob::new(&s, &fmu.description, &fmu.interfaces(), data)?)
        }
        None => job.clone(),
    };
    let mut ev = Evaluator::new(fmu, report_job.clone())?;
    let optimized = ev.simulate(&x_opt).ok();
    // The nominal model: start values, and the model's own values where an earlier stage fixed some.
    let nominal = if spec.simulation.fixed_from_earlier_stage.is_empty() {
        ev.simulate(&x0).ok()
    } else {
        let mut s = report_job.spec.clone();
        s.simulation.set.retain(|k, _| !s.simulation.fixed_from_earlier_stage.contains(k));
        let baseline = Arc::new(PreparedJob::new(&s, &fmu.description, &fmu.interfaces(), data)?);
        Evaluator::new(fmu, baseline)?.simulate(&x0).ok()
    };
    let split = job.objective.times.last().copied().unwrap_or(f64::INFINITY);
    let obj = &report_job.objective;
    let mut header = vec!["time".to_owned()];
    for t in &obj.targets {
        header.extend([
            format!("{}:measured", t.variable),
            format!("{}:nominal", t.variable),
            format!("{}:optimized", t.variable),
        ]);
    }
    let mut text = header.join(",") + "\n";
    let value = |r: &Option<fmucal_shared::sim::SimResult>, var: &str, i: usize| {
        r.as_ref().and_then(|r| r.column(var)).map(|c| c[i])
    };
    // Squared errors and counts per window: [calibration, validation] x [nominal, optimized].
    let mut sums = [[0.0f64; 2]; 2];
    let mut counts = [0usize; 2];
    for (i, t) in obj.times.iter().enumerate() {
        let w = usize::from(*t > split);
        let mut row = vec![format!("{t}")];
        for tg in &obj.targets {
            let m = tg.values[i];
            let (n, o) = (value(&nominal, &tg.variable, i), value(&optimized, &tg.variable, i));
            if !m.is_nan() {
                counts[w] += 1;
                sums[w][0] += tg.weight * (n.unwrap_or(f64::NAN) - m).powi(2);
                sums[w][1] += tg.weight * (o.unwrap_or(f64::NAN) - m).powi(2);
            }
            let cell = |v: Option<f64>| v.map(|v| format!("{v}")).unwrap_or_default();
            row.extend([if m.is_nan() { String::new() } else { format!("{m}") }, cell(n), cell(o)]);
        }
        text.push_str(&(row.join(",") + "\n"));
    }
    std::fs::write(out.join("fit.csv"), text)?;
    let window = |w: usize, start: f64, stop: f64| {
        let c = counts[w].max(1) as f64;
        let (n, o) = ((sums[w][0] / c).sqrt(), (sums[w][1] / c).sqrt());
        WindowError { start_time: start, stop_time: stop, rms_nominal: n, rms_optimized: o, scaled_rms: o / n }
    };
    let start = obj.times.first().copied().unwrap_or(0.0);
    result.errors = Some(ErrorReport {
        calibration: window(0, start, split),
        validation: (counts[1] > 0).then(|| window(1, split, obj.times.last().copied().unwrap_or(split))),
    });
    std::fs::write(out.join("result.json"), serde_json::to_string_pretty(result)?)?;
    let mut conv = String::from("round,evaluations,best_f,batch_wall_s\n");
    for h in &result.history {
        conv.push_str(&format!("{},{},{},{}\n", h.round, h.evaluations, h.best_f, h.batch_wall_s));
    }
    std::fs::write(out.join("convergence.csv"), conv)?;
    Ok(())
}
