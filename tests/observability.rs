//! Prometheus metrics, scraped over HTTP from a real coordinator and worker process during and
//! after a calibration submitted with `fmucal calibrate --coordinator`: the job is counted as
//! running and then succeeded, the worker and its slots are counted, and every evaluation (the
//! optimizer's, then the identifiability analysis's points job) is counted once by the
//! coordinator and once by the worker that ran it. With `--log-format json` every line a
//! coordinator and a worker write to stderr is one JSON object.

mod common;

use std::io::{Read, Write};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A free port on 127.0.0.1.
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

/// `GET /metrics` on `port`: the status line and the body (`None` while nothing listens).
fn scrape(port: u16) -> Option<(String, String)> {
    let mut stream = std::net::TcpStream::connect(("127.0.0.1", port)).ok()?;
    stream.set_read_timeout(Some(Duration::from_secs(10))).ok()?;
    stream.write_all(b"GET /metrics HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n").ok()?;
    let mut response = String::new();
    stream.read_to_string(&mut response).ok()?;
    let (head, body) = response.split_once("\r\n\r\n")?;
    Some((head.to_owned(), body.to_owned()))
}

/// The value of the sample named exactly `sample` (name and labels) in a scrape.
fn value(body: &str, sample: &str) -> Option<f64> {
    body.lines().find_map(|l| l.strip_prefix(sample)?.strip_prefix(' ')?.parse().ok())
}

fn scrape_until(port: u16) -> (String, String) {
    let end = Instant::now() + Duration::from_secs(60);
    loop {
        if let Some(s) = scrape(port) {
            return s;
        }
        assert!(Instant::now() < end, "nothing served metrics on port {port}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn write_job(dir: &Path) -> std::path::PathBuf {
    common::write_decay_csv(dir, common::decay_samples(&dir.join("cache"), None, 1));
    // Long enough (up to 3,000 simulations) to be scraped mid-job.
    let optimizer = "[optimizer]\nalgorithm = \"differential-evolution\"\npopulation = 12\nmax_iters = 250\nseed = 3\n\
                     x_tol = 1e-30\nf_tol = 1e-30\n";
    let text = common::decay_job_toml(5.0, optimizer);
    common::write_file(dir, "job.toml", text)
}

#[test]
fn coordinator_and_worker_metrics_count_a_job_while_it_runs_and_after() {
    let dir = tempfile::tempdir().unwrap();
    let job = write_job(dir.path());
    let (coord_port, worker_port) = (free_port(), free_port());
    let coord_metrics = format!("127.0.0.1:{coord_port}");
    let worker_metrics = format!("127.0.0.1:{worker_port}");
    let servers = common::Servers::start_with(
        dir.path(),
        2,
        &["--metrics-listen", &coord_metrics],
        &["--metrics-listen", &worker_metrics],
    );
    let (head, body) = scrape_until(coord_port);
    assert!(head.starts_with("HTTP/1.1 200"), "{head}");
    assert!(head.to_ascii_lowercase().contains("content-type: text/plain; version=0.0.4"), "{head}");
    assert!(body.contains("# TYPE fmucal_evaluation_latency_seconds histogram"), "{body}");

    let mut calibrate = Command::new(env!("CARGO_BIN_EXE_fmucal"))
        .args(["calibrate", job.to_str().unwrap(), "--coordinator", &servers.url, "--out", "out"])
        .current_dir(dir.path())
        .env("FMUCAL_TOKEN", "cli-test-token")
        .env("FMUCAL_CACHE_DIR", dir.path().join("cache"))
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut seen_running = None;
    while calibrate.try_wait().unwrap().is_none() {
        let (_, body) = scrape_until(coord_port);
        let running = value(&body, "fmucal_jobs{state=\"running\"}");
        let evaluations = value(&body, "fmucal_evaluations_total").unwrap_or(0.0);
        // The last such scrape: the gauges are refreshed on the scheduler's tick, the counters
        // at once, so the first scrape with a result can still hold the gauges of a tick before
        // the worker registered (seen on a loaded CI machine).
        if running == Some(1.0) && evaluations > 0.0 {
            seen_running = Some(body);
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = calibrate.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let during = seen_running.expect("no scrape saw the job running with evaluations done");
    assert_eq!(value(&during, "fmucal_workers"), Some(1.0), "{during}");
    assert_eq!(value(&during, "fmucal_worker_slots"), Some(2.0), "{during}");

    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("out/result.json")).unwrap()).unwrap();
    let evaluations = result["evaluations"].as_f64().unwrap();
    assert!(evaluations > 100.0, "{evaluations}");
    // `calibrate` then evaluates the identifiability points at the optimum, 2n + 1 = 3 for the
    // one parameter, as a second job.
    let evaluations = evaluations + 3.0;
    // Gauges are refreshed on the scheduler's tick (50 ms): wait for the one after the end.
    let end = Instant::now() + Duration::from_secs(10);
    let after = loop {
        let (_, body) = scrape_until(coord_port);
        if value(&body, "fmucal_jobs{state=\"succeeded\"}") == Some(2.0) || Instant::now() > end {
            break body;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    for (sample, expected) in [
        ("fmucal_jobs{state=\"running\"}", 0.0),
        ("fmucal_jobs{state=\"succeeded\"}", 2.0),
        ("fmucal_points_queued", 0.0),
        ("fmucal_points_leased", 0.0),
        ("fmucal_evaluations_total", evaluations),
        ("fmucal_failed_evaluations_total", 0.0),
        ("fmucal_evaluation_latency_seconds_count", evaluations),
    ] {
        assert_eq!(value(&after, sample), Some(expected), "{sample} in\n{after}");
    }
    let (_, worker) = scrape_until(worker_port);
    for (sample, expected) in [
        ("fmucal_worker_evaluations_total", evaluations),
        ("fmucal_worker_failed_evaluations_total", 0.0),
        ("fmucal_worker_simulation_seconds_count", evaluations),
    ] {
        assert_eq!(value(&worker, sample), Some(expected), "{sample} in\n{worker}");
    }
    assert!(value(&worker, "fmucal_worker_simulation_seconds_sum").unwrap() > 0.0, "{worker}");
    assert!(servers.stop(), "the coordinator or the worker did not stop cleanly");
}

/// The stderr lines of `child` after it was stopped with SIGTERM.
fn stopped_stderr(child: std::process::Child) -> Vec<String> {
    let _ = Command::new("kill").args(["-TERM", &child.id().to_string()]).status();
    let out = child.wait_with_output().unwrap();
    String::from_utf8_lossy(&out.stderr).lines().map(str::to_owned).collect()
}

#[test]
fn with_log_format_json_every_stderr_line_is_one_json_object() {
    let dir = tempfile::tempdir().unwrap();
    let listen = format!("127.0.0.1:{}", free_port());
    let spawn = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_fmucal"))
            .args(args)
            .env("FMUCAL_TOKEN", "json-log-token")
            .env("FMUCAL_LOG", "info,fmucal_worker=debug")
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    let data_dir = dir.path().join("coord");
    let coord =
        spawn(&["coordinator", "--log-format", "json", "--listen", &listen, "--data-dir", data_dir.to_str().unwrap()]);
    let url = format!("http://{listen}");
    let cache = dir.path().join("cache");
    let worker =
        spawn(&["worker", "--log-format", "json", "--coordinator", &url, "--cache-dir", cache.to_str().unwrap()]);
    // The worker has registered once the coordinator logs it.
    std::thread::sleep(Duration::from_secs(2));
    let worker_lines = stopped_stderr(worker);
    let coord_lines = stopped_stderr(coord);
    for (who, lines) in [("coordinator", &coord_lines), ("worker", &worker_lines)] {
        assert!(!lines.is_empty(), "the {who} logged nothing");
        for line in lines {
            let event: serde_json::Value =
                serde_json::from_str(line).unwrap_or_else(|e| panic!("{who}: not JSON ({e}): {line}"));
            assert!(event["timestamp"].is_string() && event["level"].is_string(), "{who}: {line}");
            assert!(event["fields"]["message"].is_string(), "{who}: {line}");
        }
    }
    let messages: Vec<String> = coord_lines
        .iter()
        .map(|l| {
            serde_json::from_str::<serde_json::Value>(l).unwrap()["fields"]["message"].as_str().unwrap().to_owned()
        })
        .collect();
    assert!(messages.iter().any(|m| m == &format!("coordinator listening on {listen}")), "{messages:?}");
}

/// `fmucal health URL` (what container healthchecks and probes run): exit 1 with a one-line
/// reason while a worker waits for its coordinator, exit 0 ("is SERVING") for the coordinator
/// and, once it has registered, for the worker; exit 1 where nothing listens.
#[test]
fn fmucal_health_answers_for_a_coordinator_and_a_registered_worker() {
    let dir = tempfile::tempdir().unwrap();
    let health = |url: &str| {
        let out = Command::new(env!("CARGO_BIN_EXE_fmucal")).args(["health", url, "--timeout", "2"]).output().unwrap();
        (out.status.code(), String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr))
    };
    let (coord_port, health_port) = (free_port(), free_port());
    let coordinator = format!("http://127.0.0.1:{coord_port}");
    let worker_health = format!("http://127.0.0.1:{health_port}");
    let spawn = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_fmucal"))
            .args(args)
            .env("FMUCAL_TOKEN", "health-test-token")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap()
    };
    let listen = format!("127.0.0.1:{health_port}");
    let cache = dir.path().join("cache");
    let mut worker = spawn(&[
        "worker",
        "--coordinator",
        &coordinator,
        "--health-listen",
        &listen,
        "--cache-dir",
        cache.to_str().unwrap(),
    ]);
    let (code, said) = health(&worker_health);
    assert_eq!(code, Some(1), "a worker without a coordinator passed: {said}");
    assert_eq!(said.trim().lines().count(), 1, "not one line: {said}");

    let data = dir.path().join("coord");
    let mut coord =
        spawn(&["coordinator", "--listen", &format!("127.0.0.1:{coord_port}"), "--data-dir", data.to_str().unwrap()]);
    let end = Instant::now() + Duration::from_secs(60);
    while health(&worker_health).0 != Some(0) {
        assert!(Instant::now() < end, "the worker never became SERVING: {}", health(&worker_health).1);
        std::thread::sleep(Duration::from_millis(100));
    }
    let (code, said) = health(&coordinator);
    assert_eq!(code, Some(0), "{said}");
    assert!(said.contains("is SERVING"), "{said}");
    let (code, said) = health(&format!("http://127.0.0.1:{}", free_port()));
    assert_eq!(code, Some(1), "nothing listens there: {said}");
    assert!(said.contains("cannot reach") || said.contains("did not answer"), "{said}");
    for child in [&mut worker, &mut coord] {
        let _ = child.kill();
        let _ = child.wait();
    }
}
