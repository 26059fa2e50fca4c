//! Load test, run with `cargo bench --bench load` (or `bash bench/load.sh`): a
//! `fmucal coordinator` process and `fmucal worker` processes (1 slot each) on loopback, one
//! uploaded Decay model, one reference run of a job submitted alone, then the same job submitted
//! 300 times at once from one client. Every one of the 300 must succeed with the reference's
//! result: `x_opt` and `f_opt` bitwise equal, the same evaluations (and iterations, rounds,
//! termination); any difference panics. Prints the wall time of the 300 (first submit to last
//! end), jobs/s, evaluations/s, the coordinator's peak RSS (VmHWM) and its RSS after the run,
//! and a Markdown table for docs/src/benchmarks/service.md.
//!
//! The job: k of Decay (start 1.0 in [0.1, 5]) fitted to x = exp(-1.7 t) on 0..2 s (201 points),
//! differential evolution with a fixed seed and x_tol = f_tol = 0, so it always runs its whole
//! budget of generations.
//!
//! Knobs (environment): FMUCAL_LOAD_JOBS (300), FMUCAL_LOAD_WORKERS (4), FMUCAL_LOAD_POPULATION
//! (DE population, 16), FMUCAL_LOAD_GENERATIONS (DE generations, 500).

#[path = "service_common.rs"]
mod service_common;

use std::collections::HashMap;
use std::path::Path;
use std::process::{Child, Command, ExitStatus};
use std::time::{Duration, Instant};

use fmucal_proto::convert::job_to_proto;
use fmucal_proto::v1 as pb;
use fmucal_shared::job::{JobSpec, MeasurementTable};

const TOKEN: &str = "load-bench-token-0123456789";

fn knob(name: &str, default: u64) -> u64 {
    match std::env::var(name) {
        Ok(v) => v.trim().parse().unwrap_or_else(|_| panic!("{name}={v:?} is not a non-negative integer")),
        Err(_) => default,
    }
}

/// The job, as sent: Decay's k on analytic data, DE with a fixed seed running all its generations.
fn job(model_id: &str, population: u64, generations: u64) -> pb::JobSpec {
    let toml = format!(
        "[model]\npath = \"{}\"\n[data]\n[[outputs]]\nvariable = \"x\"\ncolumn = \"x\"\n[[parameters]]\nname = \"k\"\nstart = 1.0\nlower = 0.1\nupper = 5.0\n\
         [simulation]\nstop_time = 2.0\n[optimizer]\nalgorithm = \"differential-evolution\"\npopulation = {population}\nmax_iters = {generations}\n\
         x_tol = 0\nf_tol = 0\nseed = 7\n",
        fmucal_models::example("decay").unwrap().display()
    );
    let spec = JobSpec::from_toml(&toml, Path::new(".")).unwrap();
    let time: Vec<f64> = (0..=200).map(|i| i as f64 * 0.01).collect();
    let x = time.iter().map(|t| (-1.7 * t).exp()).collect();
    let data = MeasurementTable { time, columns: vec![("x".into(), x)] };
    job_to_proto(&spec, std::slice::from_ref(&data), model_id)
}

/// `VmHWM` (peak) or `VmRSS` of a process, MB.
fn status_mb(pid: u32, field: &str) -> f64 {
    std::fs::read_to_string(format!("/proc/{pid}/status"))
        .ok()
        .and_then(|s| {
            s.lines().find(|l| l.starts_with(field)).and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map(|kb| kb / 1024.0)
        .unwrap_or(f64::NAN)
}

fn dir_bytes(dir: &Path) -> u64 {
    let Ok(entries) = std::fs::read_dir(dir) else { return 0 };
    entries
        .flatten()
        .map(|e| match e.metadata() {
            Ok(m) if m.is_dir() => dir_bytes(&e.path()),
            Ok(m) => m.len(),
            Err(_) => 0,
        })
        .sum()
}

/// The child processes (workers first, the coordinator last) and their folder. Stopping sends
/// SIGTERM and waits (10 s, then SIGKILL); dropping unstopped (a panic) does the same, and the
/// folder goes after the processes.
struct Servers {
    children: Vec<(String, Child)>,
    dir: tempfile::TempDir,
}

impl Servers {
    fn spawn(&mut self, name: &str, args: &[&str]) -> u32 {
        let log = std::fs::File::create(self.dir.path().join(format!("{name}.log"))).unwrap();
        let child =
            service_common::spawn_fmucal(args, TOKEN, log).unwrap_or_else(|e| panic!("cannot start {name}: {e}"));
        let pid = child.id();
        // The coordinator is stopped last.
        if name == "coordinator" {
            self.children.push((name.into(), child));
        } else {
            self.children.insert(0, (name.into(), child));
        }
        pid
    }

    fn stop(&mut self) -> Vec<(String, Option<ExitStatus>)> {
        let mut out = vec![];
        for (name, mut child) in std::mem::take(&mut self.children) {
            let _ = Command::new("kill").args(["-TERM", &child.id().to_string()]).status();
            let deadline = Instant::now() + Duration::from_secs(10);
            let status = loop {
                match child.try_wait() {
                    Ok(Some(s)) => break Some(s),
                    Ok(None) if Instant::now() < deadline => std::thread::sleep(Duration::from_millis(20)),
                    _ => {
                        let _ = child.kill();
                        let _ = child.wait();
                        break None;
                    }
                }
            };
            out.push((name, status));
        }
        out
    }

    /// The processes' stderr, but the coordinator's "listening on" line.
    fn logs(&self) -> Vec<String> {
        let mut names: Vec<_> = std::fs::read_dir(self.dir.path())
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".log"))
            .collect();
        names.sort();
        let mut lines = vec![];
        for n in names {
            let text = std::fs::read_to_string(self.dir.path().join(&n)).unwrap_or_default();
            for l in text.lines().filter(|l| !l.trim().is_empty() && !l.starts_with("coordinator listening on")) {
                lines.push(format!("{}: {l}", n.trim_end_matches(".log")));
            }
        }
        lines
    }
}

impl Drop for Servers {
    fn drop(&mut self) {
        self.stop();
    }
}

async fn connect(url: &str) -> service_common::Client {
    service_common::client(service_common::channel(url, Duration::from_secs(20)).await, TOKEN)
}

fn ended(status: i32) -> bool {
    status != pb::JobStatus::Queued as i32 && status != pb::JobStatus::Running as i32
}

/// What a run must reproduce, bit for bit.
fn differences(reference: &pb::JobResult, r: &pb::JobResult) -> Vec<String> {
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let mut out = vec![];
    if bits(&r.x_opt) != bits(&reference.x_opt) {
        out.push(format!("x_opt {:?} != {:?}", r.x_opt, reference.x_opt));
    }
    if r.f_opt.to_bits() != reference.f_opt.to_bits() {
        out.push(format!("f_opt {:e} != {:e}", r.f_opt, reference.f_opt));
    }
    if r.evaluations != reference.evaluations {
        out.push(format!("evaluations {} != {}", r.evaluations, reference.evaluations));
    }
    if r.iterations != reference.iterations || r.rounds != reference.rounds {
        out.push(format!(
            "iterations/rounds {}/{} != {}/{}",
            r.iterations, r.rounds, reference.iterations, reference.rounds
        ));
    }
    if r.termination != reference.termination || r.failed_evaluations != reference.failed_evaluations {
        out.push(format!(
            "termination {:?} ({} failed) != {:?} ({} failed)",
            r.termination, r.failed_evaluations, reference.termination, reference.failed_evaluations
        ));
    }
    out
}

fn main() {
    let jobs = knob("FMUCAL_LOAD_JOBS", 300) as usize;
    let workers = knob("FMUCAL_LOAD_WORKERS", 4) as usize;
    let population = knob("FMUCAL_LOAD_POPULATION", 16);
    let generations = knob("FMUCAL_LOAD_GENERATIONS", 500);
    assert!(jobs > 0 && workers > 0, "FMUCAL_LOAD_JOBS and FMUCAL_LOAD_WORKERS must be positive");

    let mut servers = Servers { children: vec![], dir: tempfile::tempdir().unwrap() };
    let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let url = format!("http://127.0.0.1:{port}");
    let data_dir = servers.dir.path().join("coordinator-data");
    let coord = servers.spawn(
        "coordinator",
        &["coordinator", "--listen", &format!("127.0.0.1:{port}"), "--data-dir", data_dir.to_str().unwrap()],
    );
    for i in 0..workers {
        let cache = servers.dir.path().join(format!("worker{i}-cache"));
        servers
            .spawn(&format!("worker{i}"), &["worker", "--coordinator", &url, "--cache-dir", cache.to_str().unwrap()]);
    }
    println!(
        "load test: {jobs} jobs on {workers} workers (1 slot each); per job: Decay k, 201 points over 2 s, \
         differential evolution population {population}, {generations} generations, seed 7"
    );

    let rt = tokio::runtime::Runtime::new().unwrap();
    let report = rt.block_on(async {
        let mut c = connect(&url).await;
        let bytes = std::fs::read(fmucal_models::example("decay").unwrap()).unwrap();
        let model = service_common::upload_model(&mut c, bytes).await;
        let spec = job(&model, population, generations);
        tokio::time::sleep(Duration::from_secs(2)).await; // let every worker register

        // The reference: the same job, alone.
        let t = Instant::now();
        let id = c.submit_job(pb::SubmitJobRequest { spec: Some(spec.clone()) }).await.unwrap().into_inner().job_id;
        let reference = loop {
            let r = c.get_job(pb::GetJobRequest { job_id: id.clone() }).await.unwrap().into_inner();
            if ended(r.status) {
                break r;
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        };
        let reference_s = t.elapsed().as_secs_f64();
        assert_eq!(
            reference.status,
            pb::JobStatus::Succeeded as i32,
            "the reference run did not succeed: {reference:?}"
        );
        let reference = reference.result.unwrap();
        println!(
            "reference run: {reference_s:.2} s, {} evaluations, k = {:?}, f = {:e} ({})",
            reference.evaluations, reference.x_opt, reference.f_opt, reference.termination
        );
        let rss_before = status_mb(coord, "VmRSS:");

        // The load: every job submitted at once, from one runtime and one connection.
        let t0 = Instant::now();
        let submits: Vec<_> = (0..jobs)
            .map(|_| {
                let mut c = c.clone();
                let spec = spec.clone();
                tokio::spawn(async move {
                    c.submit_job(pb::SubmitJobRequest { spec: Some(spec) }).await.map(|r| r.into_inner().job_id)
                })
            })
            .collect();
        let mut ids = Vec::with_capacity(jobs);
        for s in submits {
            ids.push(s.await.unwrap().unwrap_or_else(|e| panic!("a submission failed: {e:?}")));
        }
        let submitted_s = t0.elapsed().as_secs_f64();
        println!("{jobs} jobs submitted in {submitted_s:.2} s");

        // Follow them with one ListJobs every 250 ms (no per-job polling load), sampling RSS.
        let mut end_s: HashMap<String, f64> = HashMap::new();
        let mut rss_max_sampled = rss_before;
        let mut last_print = Instant::now();
        while end_s.len() < jobs {
            tokio::time::sleep(Duration::from_millis(250)).await;
            let list = c.list_jobs(pb::ListJobsRequest {}).await.unwrap().into_inner().jobs;
            let now = t0.elapsed().as_secs_f64();
            let by_id: HashMap<&str, &pb::JobSummary> = list.iter().map(|j| (j.job_id.as_str(), j)).collect();
            let mut evaluations = 0;
            for id in &ids {
                let j = by_id.get(id.as_str()).unwrap_or_else(|| panic!("job {id} is not listed"));
                evaluations += j.evaluations;
                if ended(j.status) {
                    end_s.entry(id.clone()).or_insert(now);
                }
            }
            rss_max_sampled = rss_max_sampled.max(status_mb(coord, "VmRSS:"));
            if last_print.elapsed() > Duration::from_secs(15) || end_s.len() == jobs {
                last_print = Instant::now();
                println!(
                    "  {now:6.1} s: {} of {jobs} ended, {evaluations} evaluations, coordinator RSS {:.1} MB",
                    end_s.len(),
                    status_mb(coord, "VmRSS:")
                );
            }
            assert!(now < 3600.0, "the jobs did not end within an hour");
        }
        let wall = end_s.values().cloned().fold(0.0, f64::max);

        // Every result against the reference.
        let mut bad = vec![];
        let mut evaluations = 0;
        for id in &ids {
            let r = c.get_job(pb::GetJobRequest { job_id: id.clone() }).await.unwrap().into_inner();
            match (&r.result, r.status == pb::JobStatus::Succeeded as i32) {
                (Some(result), true) => {
                    evaluations += result.evaluations;
                    let d = differences(&reference, result);
                    if !d.is_empty() {
                        bad.push(format!("{id}: {}", d.join("; ")));
                    }
                }
                _ => bad.push(format!("{id}: status {} error {:?}", r.status, r.error)),
            }
        }
        tokio::time::sleep(Duration::from_secs(1)).await;
        let rss_after = status_mb(coord, "VmRSS:");
        let peak = status_mb(coord, "VmHWM:");
        (reference, reference_s, rss_before, submitted_s, wall, evaluations, bad, rss_max_sampled, rss_after, peak)
    });
    let (reference, reference_s, rss_before, submitted_s, wall, evaluations, bad, rss_max_sampled, rss_after, peak) =
        report;
    drop(rt);
    let store_mb = dir_bytes(&data_dir) as f64 / (1 << 20) as f64;
    let logs = servers.logs();
    let stopped = servers.stop();

    println!(
        "\n{jobs} jobs ended {wall:.1} s after the first submission: {:.2} jobs/s, {evaluations} evaluations, \
         {:.0} evaluations/s",
        jobs as f64 / wall,
        evaluations as f64 / wall
    );
    println!(
        "coordinator RSS: {rss_before:.1} MB before the load, {rss_max_sampled:.1} MB highest sampled, \
         {rss_after:.1} MB after; peak (VmHWM) {peak:.1} MB; store on disk {store_mb:.1} MB"
    );
    for (name, status) in &stopped {
        if !status.is_some_and(|s| s.success()) {
            println!("{name} did not exit cleanly on SIGTERM: {status:?}");
        }
    }
    if logs.is_empty() {
        println!("no warnings or errors in the coordinator's or the workers' logs");
    } else {
        println!("{} log lines from the coordinator and workers (first 20):", logs.len());
        for l in logs.iter().take(20) {
            println!("  {l}");
        }
    }
    if !bad.is_empty() {
        for b in bad.iter().take(20) {
            println!("MISMATCH {b}");
        }
        panic!("{} of {jobs} jobs differ from the reference run", bad.len());
    }
    println!("all {jobs} results identical to the reference run (x_opt and f_opt bitwise, same evaluations)\n");

    println!("| load test ({jobs} jobs, {workers} workers × 1 slot, 2 cores) | value |");
    println!("|---|---|");
    println!(
        "| job | Decay k, 201 points over 2 s, DE population {population} × {generations} generations (seed 7), {} evaluations |",
        reference.evaluations
    );
    println!("| reference run, alone | {reference_s:.2} s |");
    println!("| {jobs} jobs submitted at once: all submitted | {submitted_s:.2} s |");
    println!("| wall time, first submission to last end | {wall:.1} s |");
    println!("| throughput | {:.2} jobs/s, {:.0} evaluations/s |", jobs as f64 / wall, evaluations as f64 / wall);
    println!("| coordinator peak RSS (VmHWM) | {peak:.1} MB |");
    println!("| coordinator RSS before / after the {jobs} jobs | {rss_before:.1} / {rss_after:.1} MB |");
    println!("| results identical to the reference run | {jobs} of {jobs} |");
}
