//! Service benchmarks, run with `cargo bench --bench service`: an in-process
//! coordinator and real `fmucal worker` processes on loopback.
//!
//! - **Overhead per evaluation**: Decay over 0.01 s (a near-zero-cost FMU) through one worker,
//!   DE population 32, against evaluating the same points in-process.
//! - **Scaling**: Decay with `delay = 0.05` (50 ms of wall time per simulation), DE population
//!   32 for 10 generations (320 points), with 1, 2, 4, 8 and 16 workers; efficiency =
//!   T₁ / (N·T_N), measured from submission (each worker's one-time job start included).
//! - **Worker RSS** after 10,000 evaluations (growth from the 500th evaluation on).

#[path = "service_common.rs"]
mod service_common;

use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::time::{Duration, Instant};

use fmucal_proto::convert::job_to_proto;
use fmucal_proto::v1 as pb;
use fmucal_shared::fmu::Fmu;
use fmucal_shared::job::{Evaluator, JobSpec, MeasurementTable, PreparedJob};

const TOKEN: &str = "bench-token";

fn job(population: usize, generations: u64, delay: f64, stop: f64) -> (JobSpec, MeasurementTable) {
    let toml = format!(
        "[model]\npath = \"{}\"\n[data]\n[[outputs]]\nvariable = \"x\"\ncolumn = \"x\"\n[[parameters]]\nname = \"k\"\nstart = 1.0\nlower = 0.1\nupper = 5.0\n\
         [simulation]\nstop_time = {stop}\nset = {{ delay = {delay} }}\n[optimizer]\nalgorithm = \"differential-evolution\"\npopulation = {population}\nmax_iters = {generations}\n\
         x_tol = 0\nf_tol = 0\nseed = 1\n",
        fmucal_models::example("decay").unwrap().display()
    );
    let spec = JobSpec::from_toml(&toml, std::path::Path::new(".")).unwrap();
    let data = MeasurementTable { time: vec![0.0, stop], columns: vec![("x".into(), vec![1.0, (-1.7 * stop).exp()])] };
    (spec, data)
}

fn worker(url: &str, cache: &std::path::Path) -> Child {
    Command::new(env!("CARGO_BIN_EXE_fmucal"))
        .args(["worker", "--coordinator", url, "--cache-dir"])
        .arg(cache)
        .env("FMUCAL_TOKEN", TOKEN)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("start a worker")
}

fn rss_mb(pid: u32) -> f64 {
    std::fs::read_to_string(format!("/proc/{pid}/status"))
        .ok()
        .and_then(|s| {
            s.lines().find(|l| l.starts_with("VmRSS:")).and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map(|kb| kb / 1024.0)
        .unwrap_or(f64::NAN)
}

/// Runs a job on `workers` fresh worker processes; returns (seconds from submit to done,
/// evaluations, RSS samples of the first worker at `sample_at` evaluations and at the end).
async fn run(spec: &JobSpec, data: &MeasurementTable, workers: usize, sample_at: u64) -> (f64, u64, f64, f64) {
    let dir = tempfile::tempdir().unwrap();
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let url = format!("http://{}", listener.local_addr().unwrap());
    let config = fmucal_coordinator::Config {
        token: Some(TOKEN.into()),
        ..fmucal_coordinator::Config::new(dir.path().join("c"))
    };
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    let server = tokio::spawn(fmucal_coordinator::run(config, listener, async {
        let _ = stop_rx.await;
    }));
    let mut children: Vec<Child> = (0..workers).map(|_| worker(&url, &dir.path().join("w"))).collect();
    let ch = tonic::transport::Endpoint::from_shared(url.clone()).unwrap().connect().await.unwrap();
    let mut c = service_common::client(ch, TOKEN);
    let bytes = std::fs::read(spec.model.path.as_ref().unwrap()).unwrap();
    let model = service_common::upload_model(&mut c, bytes).await;
    tokio::time::sleep(Duration::from_millis(2000)).await; // let every worker register
    let t0 = Instant::now();
    let id = c
        .submit_job(pb::SubmitJobRequest { spec: Some(job_to_proto(spec, std::slice::from_ref(data), &model)) })
        .await
        .unwrap()
        .into_inner()
        .job_id;
    // Follow the job through its event stream (no polling load on the shared cores).
    let mut early = f64::NAN;
    let mut events = c.watch_job(pb::WatchJobRequest { job_id: id.clone() }).await.unwrap().into_inner();
    while let Some(ev) = events.message().await.unwrap() {
        if early.is_nan() && ev.evaluations >= sample_at {
            early = rss_mb(children[0].id());
        }
        if ev.status != pb::JobStatus::Running as i32 {
            break;
        }
    }
    let wall = t0.elapsed().as_secs_f64();
    let evaluations =
        c.get_job(pb::GetJobRequest { job_id: id.clone() }).await.unwrap().into_inner().result.unwrap().evaluations;
    let late = rss_mb(children[0].id());
    for ch in &mut children {
        let _ = ch.kill();
        let _ = ch.wait();
    }
    let _ = stop_tx.send(());
    let _ = server.await;
    (wall, evaluations, early, late)
}

fn in_process_seconds_per_eval(spec: &JobSpec, data: &MeasurementTable, n: usize) -> f64 {
    let fmu = Arc::new(Fmu::load(spec.model.path.as_ref().unwrap()).unwrap());
    let job =
        Arc::new(PreparedJob::new(spec, &fmu.description, &fmu.interfaces(), std::slice::from_ref(data)).unwrap());
    let mut ev = Evaluator::new(&fmu, job).unwrap();
    let t = Instant::now();
    for i in 0..n {
        ev.evaluate(&[0.1 + 4.9 * (i as f64 / n as f64)], 0, false);
    }
    t.elapsed().as_secs_f64() / n as f64
}

fn main() {
    let rt = tokio::runtime::Runtime::new().unwrap();
    let json_out = std::env::args().skip_while(|a| a != "--json").nth(1);

    let (spec, data) = job(32, 60, 0.0, 0.01);
    let local = in_process_seconds_per_eval(&spec, &data, 2000);
    let (wall, evals, _, _) = rt.block_on(run(&spec, &data, 1, u64::MAX));
    let per_point = wall / evals as f64;
    println!("in-process evaluation      {:.1} us", local * 1e6);
    println!("through one worker         {:.1} us per point ({evals} points)", per_point * 1e6);
    println!("overhead per evaluation    {:.1} us", (per_point - local) * 1e6);

    let (spec, data) = job(32, 9, 0.05, 0.01);
    let mut scaling = vec![];
    let mut t1 = 0.0;
    for n in [1usize, 2, 4, 8, 16] {
        let (wall, evals, _, _) = rt.block_on(run(&spec, &data, n, u64::MAX));
        if n == 1 {
            t1 = wall;
        }
        let eff = t1 / (n as f64 * wall);
        println!("{n:>2} workers: {wall:.3} s for {evals} evaluations, efficiency {eff:.3}");
        scaling.push(serde_json::json!({"workers": n, "seconds": wall, "evaluations": evals, "efficiency": eff}));
    }

    let (spec, data) = job(50, 200, 0.0, 0.01);
    let (wall, evals, early, late) = rt.block_on(run(&spec, &data, 1, 500));
    println!(
        "worker RSS: {early:.1} MB after 500 evaluations, {late:.1} MB after {evals} ({wall:.1} s); growth {:.2} MB",
        late - early
    );

    if let Some(path) = json_out {
        let j = serde_json::json!({
            "in_process_us": local * 1e6, "per_point_us": per_point * 1e6, "overhead_us": (per_point - local) * 1e6,
            "scaling": scaling, "rss_early_mb": early, "rss_late_mb": late, "rss_evaluations": evals,
        });
        std::fs::write(path, j.to_string()).unwrap();
    }
}
