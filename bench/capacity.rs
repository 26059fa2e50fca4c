//! Capacity benchmark, run with `bash bench/capacity.sh` (or `cargo bench --bench capacity --
//! [RESULTS]`): what one `fmucal coordinator` process sustains with 1,000 worker slots. The
//! slots are simulated in this process: tasks that speak the real worker protocol (Register,
//! Heartbeat, FetchModel once per worker, FetchJob once per worker and job, and PollWork
//! through the real worker's poller, `worker/src/poller.rs`: one poll for all of a worker's
//! slots, asking for up to 4 points per slot and returning results with the next poll) and
//! answer each point after a set simulation time (a sleep; 0 answers at once) with a value
//! computed from x alone, so every job is deterministic. The 1,000 slots are 250 workers
//! of 4 slots, each worker on its own HTTP/2 connection (the coordinator's default cap is 512).
//! A submitter keeps a set number of jobs running (DE on Decay's parameters by default, with
//! x_tol = f_tol = 0 so each runs its whole budget); finished jobs are deleted by the
//! coordinator's retention (`--keep-finished-jobs 50`).
//!
//! After a warm-up it counts RESULTS results (default 1,000,000) and reports: results per second
//! against the ideal slots / simulation time; lease-to-result latency (from the slot receiving
//! a point to the coordinator acknowledging its result, i.e. the answer to the poll that
//! carried it) p50 and p99, and the poll round trip alone; the CPU of the coordinator process
//! (from /proc/PID/stat) per result and in cores, of this process (the slots), and the
//! machine's idle share (from /proc/stat: the machine has 2 cores and other work may run);
//! the coordinator's RSS over the run with its slope per million results; the store's file
//! size. Then it SIGKILLs the coordinator with its jobs running and reads the store: the
//! journal's size (redb's pages of table `journal`) per journaled evaluation.
//!
//! Knobs (environment): FMUCAL_CAPACITY_SIM_MS (50), FMUCAL_CAPACITY_SLOTS (1000),
//! FMUCAL_CAPACITY_CONNECTIONS (250), FMUCAL_CAPACITY_JOBS (running at once, 150),
//! FMUCAL_CAPACITY_OPTIMIZER (de, cma-es, nm or ls), FMUCAL_CAPACITY_POPULATION (DE and
//! CMA-ES, 20), FMUCAL_CAPACITY_FEVALS (evaluations per job, 4000), FMUCAL_CAPACITY_PARAMETERS
//! (1 to 4, 2), FMUCAL_CAPACITY_WARMUP_S (5).

#[path = "service_common.rs"]
mod service_common;

use std::collections::{HashMap, HashSet};
use std::path::Path;
use std::process::{Child, Command};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use fmucal_proto::auth::AttachToken;
use fmucal_proto::convert::job_to_proto;
use fmucal_proto::v1 as pb;
use fmucal_proto::v1::worker_pool_client::WorkerPoolClient;
use fmucal_shared::job::{JobSpec, MeasurementTable};
use fmucal_worker::poller::{self, Inbox, Observer, PollObservation, PollerContext};
use redb::{ReadableDatabase, ReadableTable, ReadableTableMetadata, TableDefinition};
use tokio::sync::RwLock;
use tonic::service::interceptor::InterceptedService;
use tonic::transport::Channel;

const TOKEN: &str = "capacity-bench-token-0123456789";
/// The measured values per evaluation (the data's 21 samples of x): a least-squares result's
/// residual count.
const SAMPLES: usize = 21;
/// Decay's real parameters the jobs calibrate, with start and bounds.
const PARAMETERS: [(&str, f64, f64, f64); 4] =
    [("k", 1.0, 0.1, 5.0), ("kickAmount", 0.0, -1.0, 1.0), ("kickTime", 5.0, 1.0, 10.0), ("crashTime", 5.0, 1.0, 10.0)];
/// Where the simulated objective has its minimum, per parameter.
const OPTIMUM: [f64; 4] = [1.7, 0.25, 3.0, 7.5];
/// Latency histogram: 10 µs buckets up to 5 s.
const BUCKET_US: u64 = 10;
const BUCKETS: usize = 500_000;

type Worker = WorkerPoolClient<InterceptedService<Channel, AttachToken>>;

fn knob(name: &str, default: u64) -> u64 {
    match std::env::var(name) {
        Ok(v) => v.trim().parse().unwrap_or_else(|_| panic!("{name}={v:?} is not a non-negative integer")),
        Err(_) => default,
    }
}

#[derive(Clone)]
struct Knobs {
    results: u64,
    sim: Duration,
    slots: usize,
    connections: usize,
    jobs: usize,
    optimizer: String,
    population: u64,
    fevals: u64,
    parameters: usize,
    warmup: Duration,
}

impl Knobs {
    fn read() -> Knobs {
        // `cargo bench` passes `--bench`; the one other argument is the result count.
        let results = std::env::args()
            .skip(1)
            .find(|a| !a.starts_with('-'))
            .map(|a| a.replace('_', "").parse().unwrap_or_else(|_| panic!("RESULTS: {a:?} is not a count")))
            .unwrap_or(1_000_000);
        let k = Knobs {
            results,
            sim: Duration::from_millis(knob("FMUCAL_CAPACITY_SIM_MS", 50)),
            slots: knob("FMUCAL_CAPACITY_SLOTS", 1000) as usize,
            connections: knob("FMUCAL_CAPACITY_CONNECTIONS", 250) as usize,
            jobs: knob("FMUCAL_CAPACITY_JOBS", 150) as usize,
            optimizer: std::env::var("FMUCAL_CAPACITY_OPTIMIZER").unwrap_or_else(|_| "de".into()),
            population: knob("FMUCAL_CAPACITY_POPULATION", 20),
            fevals: knob("FMUCAL_CAPACITY_FEVALS", 4000),
            parameters: knob("FMUCAL_CAPACITY_PARAMETERS", 2) as usize,
            warmup: Duration::from_secs(knob("FMUCAL_CAPACITY_WARMUP_S", 5)),
        };
        assert!(k.results > 0, "RESULTS must be positive");
        assert!(k.slots > 0 && k.jobs > 0, "FMUCAL_CAPACITY_SLOTS and FMUCAL_CAPACITY_JOBS must be positive");
        assert!(
            (1..=k.slots).contains(&k.connections) && k.connections <= 500,
            "FMUCAL_CAPACITY_CONNECTIONS: 1 to min(slots, 500), within the coordinator's cap of 512"
        );
        assert!(
            k.slots.div_ceil(k.connections) <= fmucal_proto::MAX_SLOTS as usize,
            "FMUCAL_CAPACITY_SLOTS / FMUCAL_CAPACITY_CONNECTIONS: at most {} slots per worker",
            fmucal_proto::MAX_SLOTS
        );
        assert!((1..=4).contains(&k.parameters), "FMUCAL_CAPACITY_PARAMETERS: 1 to 4, not {}", k.parameters);
        assert!(
            ["de", "cma-es", "nm", "ls"].contains(&k.optimizer.as_str()),
            "FMUCAL_CAPACITY_OPTIMIZER: de, cma-es, nm or ls, not {:?}",
            k.optimizer
        );
        k
    }

    fn optimizer_toml(&self, seed: u64) -> String {
        let budget = format!("max_fevals = {}\nmax_iters = 1000000\nx_tol = 0\nf_tol = 0\n", self.fevals);
        match self.optimizer.as_str() {
            "de" => format!(
                "algorithm = \"differential-evolution\"\npopulation = {}\nseed = {seed}\n{budget}",
                self.population
            ),
            "cma-es" => format!("algorithm = \"cma-es\"\npopulation = {}\nseed = {seed}\n{budget}", self.population),
            "nm" => format!("algorithm = \"nelder-mead\"\n{budget}"),
            _ => format!("algorithm = \"least-squares\"\n{budget}"),
        }
    }
}

/// The job: Decay's first `parameters` real parameters on 21 samples of exp(-1.7 t).
fn job(k: &Knobs, model_id: &str, seed: u64) -> pb::JobSpec {
    let params: String = PARAMETERS[..k.parameters]
        .iter()
        .map(|(n, s, lo, hi)| format!("[[parameters]]\nname = \"{n}\"\nstart = {s}\nlower = {lo}\nupper = {hi}\n"))
        .collect();
    let toml = format!(
        "[model]\npath = \"{}\"\n[data]\n[[outputs]]\nvariable = \"x\"\ncolumn = \"x\"\n{params}\
         [simulation]\nstop_time = 2.0\n[optimizer]\n{}",
        fmucal_models::example("decay").unwrap().display(),
        k.optimizer_toml(seed)
    );
    let spec = JobSpec::from_toml(&toml, Path::new(".")).unwrap();
    let time: Vec<f64> = (0..SAMPLES).map(|i| i as f64 * 0.1).collect();
    let x = time.iter().map(|t| (-1.7 * t).exp()).collect();
    job_to_proto(&spec, &[MeasurementTable { time, columns: vec![("x".into(), x)] }], model_id)
}

/// The simulated model: residuals from x alone (each sample's share of x - optimum), and their
/// sum of squares.
fn answer(a: &pb::Assignment) -> pb::PointResult {
    let residuals: Vec<f64> = (0..SAMPLES)
        .map(|i| {
            let j = i % a.x.len();
            (a.x[j] - OPTIMUM[j]) * (1.0 + 0.1 * i as f64) / (SAMPLES as f64).sqrt()
        })
        .collect();
    pb::PointResult {
        job_id: a.job_id.clone(),
        point_id: a.point_id,
        status: pb::PointStatus::Ok as i32,
        value: residuals.iter().map(|r| r * r).sum(),
        message: String::new(),
        wall_s: 0.0,
        residuals: if a.want_residuals { residuals } else { vec![] },
    }
}

/// What the slots measure, shared.
struct Counters {
    /// Results acknowledged by the coordinator.
    results: AtomicU64,
    /// Whether latencies are being recorded (the measured window).
    recording: std::sync::atomic::AtomicBool,
    lease_to_ack: Mutex<Vec<u64>>,
    round_trip: Mutex<Vec<u64>>,
    polls: AtomicU64,
    empty_polls: AtomicU64,
    errors: AtomicU64,
    registrations: AtomicU64,
    /// Points evaluated and their simulated time, µs (the sleep as it came out).
    simulated: AtomicU64,
    simulated_us: AtomicU64,
}

/// What the measured window saw.
struct Measured {
    /// Its length, s.
    wall: f64,
    /// Results acknowledged in it.
    done: u64,
    /// CPU seconds of the coordinator and of this process.
    coord_cpu: f64,
    bench_cpu: f64,
    /// The machine's busy fraction.
    machine_busy: f64,
    /// (results done, coordinator RSS in MB), every half second.
    samples: Vec<(f64, f64)>,
    /// The coordinator's peak RSS, MB.
    peak: f64,
    /// The store file's largest size, bytes.
    file_max: u64,
    /// Mean simulated time of a point, ms.
    mean_sim_ms: f64,
    polls: u64,
    empty: u64,
    jobs_submitted: u64,
    /// The coordinator's CPU seconds by thread: store writer, tokio runtime, other.
    threads: Vec<f64>,
}

fn record(h: &Mutex<Vec<u64>>, values: &[Duration]) {
    let mut h = h.lock().unwrap();
    for d in values {
        let b = ((d.as_micros() as u64) / BUCKET_US).min(BUCKETS as u64 - 1) as usize;
        h[b] += 1;
    }
}

/// The `q` quantile of a histogram, ms.
fn quantile(h: &[u64], q: f64) -> f64 {
    let n: u64 = h.iter().sum();
    if n == 0 {
        return f64::NAN;
    }
    let want = (q * n as f64).ceil().max(1.0) as u64;
    let mut seen = 0;
    for (b, c) in h.iter().enumerate() {
        seen += c;
        if seen >= want {
            return (b as u64 * BUCKET_US + BUCKET_US / 2) as f64 / 1000.0;
        }
    }
    f64::INFINITY
}

async fn connect(url: &str) -> Channel {
    service_common::channel(url, Duration::from_secs(30)).await
}

fn token() -> AttachToken {
    AttachToken::new(Some(TOKEN)).unwrap()
}

async fn register(w: &mut Worker, slots: usize, name: &str, counters: &Counters) -> String {
    let req = pb::RegisterRequest {
        protocol_version: fmucal_proto::PROTOCOL_VERSION,
        slots: slots as u32,
        name: name.into(),
    };
    counters.registrations.fetch_add(1, Ordering::Relaxed);
    w.register(req).await.unwrap_or_else(|e| panic!("registration refused: {e}")).into_inner().worker_id
}

/// One simulated worker: its connection, registration and heartbeats, the real worker's
/// poller (`fmucal_worker::poller`: one long poll for all its slots) and `slots` slot tasks
/// that "simulate" the points they take.
async fn worker(url: String, index: usize, slots: usize, model_id: String, sim: Duration, counters: Arc<Counters>) {
    let mut w = WorkerPoolClient::with_interceptor(connect(&url).await, token())
        .max_decoding_message_size(fmucal_proto::MAX_MESSAGE_BYTES);
    let name = format!("sim-{index}");
    let id = Arc::new(RwLock::new(register(&mut w, slots, &name, &counters).await));
    // The model, once, as a worker with an empty cache fetches it.
    let mut stream = w.fetch_model(pb::FetchModelRequest { model_id }).await.expect("FetchModel refused").into_inner();
    while stream.message().await.expect("FetchModel broke off").is_some() {}
    let fetched: Arc<Mutex<HashSet<String>>> = Arc::default();
    let mut tasks = tokio::task::JoinSet::new();
    {
        let (mut w, id, counters) = (w.clone(), id.clone(), counters.clone());
        tasks.spawn(async move {
            loop {
                tokio::time::sleep(Duration::from_secs(1)).await;
                let worker_id = id.read().await.clone();
                match w.heartbeat(pb::HeartbeatRequest { worker_id }).await {
                    Ok(r) if !r.get_ref().known => {
                        let new = register(&mut w, slots, &name, &counters).await;
                        *id.write().await = new;
                    }
                    Ok(_) => {}
                    Err(e) => {
                        if counters.errors.fetch_add(1, Ordering::Relaxed) < 5 {
                            eprintln!("a heartbeat failed: {e}");
                        }
                    }
                }
            }
        });
    }
    // When each point held arrived, for its lease-to-result latency.
    let leased: Arc<Mutex<HashMap<(String, u64), Instant>>> = Arc::default();
    let observer: Observer = {
        let (counters, leased) = (counters.clone(), leased.clone());
        Arc::new(move |o: &PollObservation<'_>| {
            let acked = Instant::now();
            counters.polls.fetch_add(1, Ordering::Relaxed);
            // Points handed back unevaluated are not results.
            let back = pb::PointStatus::NotEvaluated as i32;
            let evaluated = o.results.iter().filter(|r| r.status != back).count();
            counters.results.fetch_add(evaluated as u64, Ordering::Relaxed);
            if o.assignments == 0 {
                counters.empty_polls.fetch_add(1, Ordering::Relaxed);
            }
            let mut leased = leased.lock().unwrap();
            let lat: Vec<Duration> = o
                .results
                .iter()
                .filter_map(|r| leased.remove(&(r.job_id.clone(), r.point_id)))
                .map(|at| acked - at)
                .collect();
            if counters.recording.load(Ordering::Relaxed) {
                record(&counters.lease_to_ack, &lat);
                if !o.results.is_empty() && o.assignments > 0 {
                    record(&counters.round_trip, &[o.round_trip]);
                }
            }
        })
    };
    // Never stopped: the benchmark ends with the process.
    let (_stop, stop) = tokio::sync::watch::channel(false);
    let (_give_up, give_up) = tokio::sync::watch::channel(false);
    let inbox = Arc::new(Inbox::default());
    let poller = PollerContext {
        client: w.clone(),
        worker_id: id.clone(),
        slots,
        stop,
        give_up,
        deadline: None,
        observer: Some(observer),
    };
    tasks.spawn(poller::run(poller, inbox.clone()));
    for _ in 0..slots {
        let (w, inbox, counters, fetched, leased) =
            (w.clone(), inbox.clone(), counters.clone(), fetched.clone(), leased.clone());
        tasks.spawn(slot(w, inbox, sim, counters, fetched, leased));
    }
    while tasks.join_next().await.is_some() {}
}

/// One slot: takes the points the poller brought, "simulates" each, and hands its result to
/// the poller for its next poll.
async fn slot(
    mut w: Worker,
    inbox: Arc<Inbox>,
    sim: Duration,
    counters: Arc<Counters>,
    fetched: Arc<Mutex<HashSet<String>>>,
    leased: Arc<Mutex<HashMap<(String, u64), Instant>>>,
) {
    while let Some(taken) = inbox.next().await {
        let a = &taken.point;
        leased.lock().unwrap().insert((a.job_id.clone(), a.point_id), taken.received.into_std());
        let first = fetched.lock().unwrap().insert(a.job_id.clone());
        if first {
            // As the worker's job cache: the spec and data once per job.
            if w.fetch_job(pb::FetchJobRequest { job_id: a.job_id.clone() }).await.is_err() {
                counters.errors.fetch_add(1, Ordering::Relaxed);
            }
        }
        if !sim.is_zero() {
            let start = Instant::now();
            tokio::time::sleep(sim).await;
            counters.simulated.fetch_add(1, Ordering::Relaxed);
            counters.simulated_us.fetch_add(start.elapsed().as_micros() as u64, Ordering::Relaxed);
        }
        let result = answer(a);
        taken.finish(result);
    }
}

/// utime + stime of a process (`self` for this one), seconds.
fn cpu_s(pid: &str) -> f64 {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
    // Fields after the command name in parentheses: state is the 3rd field, utime the 14th.
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11).and_then(|v| v.parse().ok()).unwrap_or(f64::NAN)
        + f.get(12).and_then(|v| v.parse::<f64>().ok()).unwrap_or(f64::NAN);
    ticks / clock_ticks()
}

fn clock_ticks() -> f64 {
    static TICKS: std::sync::OnceLock<f64> = std::sync::OnceLock::new();
    *TICKS.get_or_init(|| {
        Command::new("getconf")
            .arg("CLK_TCK")
            .output()
            .ok()
            .and_then(|o| String::from_utf8(o.stdout).ok()?.trim().parse().ok())
            .unwrap_or(100.0)
    })
}

/// CPU seconds of a process's threads, by thread name: the store writer (`fmucal-store`), the
/// tokio runtime's threads (the scheduler task, the gRPC services) and the rest.
fn cpu_by_thread(pid: u32) -> [f64; 3] {
    let mut out = [0.0; 3];
    let Ok(tasks) = std::fs::read_dir(format!("/proc/{pid}/task")) else { return out };
    for t in tasks.flatten() {
        let tid = t.file_name().to_string_lossy().into_owned();
        let comm = std::fs::read_to_string(format!("/proc/{pid}/task/{tid}/comm")).unwrap_or_default();
        let i = if comm.starts_with("fmucal-store") {
            0
        } else if comm.starts_with("tokio") {
            1
        } else {
            2
        };
        out[i] += cpu_s(&format!("{pid}/task/{tid}"));
    }
    out
}

/// The machine's (busy, total) jiffies from /proc/stat.
fn machine_jiffies() -> (f64, f64) {
    let stat = std::fs::read_to_string("/proc/stat").unwrap_or_default();
    let cpu: Vec<f64> =
        stat.lines().next().unwrap_or("").split_whitespace().skip(1).filter_map(|v| v.parse().ok()).collect();
    let total: f64 = cpu.iter().sum();
    let idle = cpu.get(3).copied().unwrap_or(0.0) + cpu.get(4).copied().unwrap_or(0.0);
    (total - idle, total)
}

fn rss_mb(pid: u32, field: &str) -> f64 {
    std::fs::read_to_string(format!("/proc/{pid}/status"))
        .ok()
        .and_then(|s| {
            s.lines().find(|l| l.starts_with(field)).and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

/// Least-squares slope of y over x.
fn slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (mx, my) = (points.iter().map(|p| p.0).sum::<f64>() / n, points.iter().map(|p| p.1).sum::<f64>() / n);
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    sxy / sxx
}

struct Coordinator {
    child: Child,
    dir: tempfile::TempDir,
}

impl Drop for Coordinator {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The journal's and the states' size in a stopped coordinator's store.
struct StoreSize {
    file: u64,
    journal_bytes: u64,
    journal_stored: u64,
    journal_blocks: u64,
    journal_points: u64,
    states_bytes: u64,
    states: u64,
}

fn store_size(path: &Path) -> StoreSize {
    const JOURNAL: TableDefinition<(&str, u64), &[u8]> = TableDefinition::new("journal");
    const STATES: TableDefinition<&str, &str> = TableDefinition::new("job_states");
    let file = std::fs::metadata(path).map_or(0, |m| m.len());
    let db = redb::Database::create(path).unwrap();
    let tx = db.begin_read().unwrap();
    let journal = tx.open_table(JOURNAL).unwrap();
    let s = journal.stats().unwrap();
    let mut points = 0;
    for entry in journal.iter().unwrap() {
        let (_, v) = entry.unwrap();
        points += fmucal_coordinator::journal::decode(v.value()).map_or(0, |p| p.len()) as u64;
    }
    let states = tx.open_table(STATES).unwrap();
    let st = states.stats().unwrap();
    StoreSize {
        file,
        journal_bytes: s.stored_bytes() + s.metadata_bytes() + s.fragmented_bytes(),
        journal_stored: s.stored_bytes(),
        journal_blocks: journal.len().unwrap(),
        journal_points: points,
        states_bytes: st.stored_bytes() + st.metadata_bytes() + st.fragmented_bytes(),
        states: states.len().unwrap(),
    }
}

fn main() {
    let k = Knobs::read();
    let dir = tempfile::tempdir().unwrap();
    let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let url = format!("http://127.0.0.1:{port}");
    let data_dir = dir.path().join("coordinator-data");
    let log = std::fs::File::create(dir.path().join("coordinator.log")).unwrap();
    let listen = format!("127.0.0.1:{port}");
    let args =
        ["coordinator", "--listen", &listen, "--keep-finished-jobs", "50", "--data-dir", data_dir.to_str().unwrap()];
    let child = service_common::spawn_fmucal(&args, TOKEN, log).expect("cannot start the coordinator");
    let pid = child.id();
    let mut coordinator = Coordinator { child, dir };
    let ideal = if k.sim.is_zero() { f64::NAN } else { k.slots as f64 / k.sim.as_secs_f64() };
    println!(
        "capacity: {} slots over {} connections, simulation {} ms, {} jobs running at once \
         ({} on {} of Decay's parameters, {} evaluations each), {} results measured after a {} s warm-up",
        k.slots,
        k.connections,
        k.sim.as_millis(),
        k.jobs,
        k.optimizer,
        k.parameters,
        k.fevals,
        k.results,
        k.warmup.as_secs()
    );

    let rt = tokio::runtime::Runtime::new().unwrap();
    let counters = Arc::new(Counters {
        results: AtomicU64::new(0),
        recording: false.into(),
        lease_to_ack: Mutex::new(vec![0; BUCKETS]),
        round_trip: Mutex::new(vec![0; BUCKETS]),
        polls: AtomicU64::new(0),
        empty_polls: AtomicU64::new(0),
        errors: AtomicU64::new(0),
        registrations: AtomicU64::new(0),
        simulated: AtomicU64::new(0),
        simulated_us: AtomicU64::new(0),
    });
    let m = rt.block_on(async {
        let mut c = service_common::client(connect(&url).await, TOKEN);
        let bytes = std::fs::read(fmucal_models::example("decay").unwrap()).unwrap();
        let model = service_common::upload_model(&mut c, bytes).await;
        // The workers: slots spread over the connections as evenly as they go.
        for i in 0..k.connections {
            let slots = k.slots / k.connections + usize::from(i < k.slots % k.connections);
            tokio::spawn(worker(url.clone(), i, slots, model.clone(), k.sim, counters.clone()));
        }
        // The submitter: keeps `jobs` running, each with its own seed.
        let submitted = Arc::new(AtomicU64::new(0));
        // Jobs the coordinator holds (running, and finished but not yet deleted), last seen.
        let held = Arc::new(AtomicU64::new(0));
        let failed = Arc::new(Mutex::new(Vec::<String>::new()));
        {
            let (mut c, k, model, submitted, failed, held) =
                (c.clone(), k.clone(), model.clone(), submitted.clone(), failed.clone(), held.clone());
            tokio::spawn(async move {
                let mut seen_failed = HashSet::new();
                loop {
                    let jobs = c.list_jobs(pb::ListJobsRequest {}).await.unwrap().into_inner().jobs;
                    held.store(jobs.len() as u64, Ordering::Relaxed);
                    // Queued jobs count too: a job is queued until its first batch is asked.
                    let live = [pb::JobStatus::Queued as i32, pb::JobStatus::Running as i32];
                    let running = jobs.iter().filter(|j| live.contains(&j.status)).count();
                    for j in jobs.iter().filter(|j| j.status == pb::JobStatus::Failed as i32) {
                        if seen_failed.insert(j.job_id.clone()) {
                            failed.lock().unwrap().push(j.job_id.clone());
                        }
                    }
                    for _ in running..k.jobs {
                        let seed = submitted.fetch_add(1, Ordering::Relaxed);
                        c.submit_job(pb::SubmitJobRequest { spec: Some(job(&k, &model, seed)) }).await.unwrap();
                    }
                    tokio::time::sleep(Duration::from_millis(200)).await;
                }
            });
        }
        // Warm-up: every slot registered and the warm-up time passed.
        let started = Instant::now();
        while counters.registrations.load(Ordering::Relaxed) < k.connections as u64 || started.elapsed() < k.warmup {
            assert!(started.elapsed() < Duration::from_secs(120), "the workers did not all register");
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        counters.recording.store(true, Ordering::Relaxed);
        let r0 = counters.results.load(Ordering::Relaxed);
        let (sim0, simus0) =
            (counters.simulated.load(Ordering::Relaxed), counters.simulated_us.load(Ordering::Relaxed));
        let (polls0, empty0) = (counters.polls.load(Ordering::Relaxed), counters.empty_polls.load(Ordering::Relaxed));
        let t0 = Instant::now();
        let (cc0, bc0, m0) = (cpu_s(&pid.to_string()), cpu_s("self"), machine_jiffies());
        let threads0 = cpu_by_thread(pid);
        let rss0 = rss_mb(pid, "VmRSS:");
        let mut samples: Vec<(f64, f64)> = vec![(0.0, rss0)];
        let mut file_max = 0u64;
        let mut last_print = Instant::now();
        // CPU seconds and results at the last print, for the cost since.
        let mut at_print = (cc0, 0u64);
        loop {
            tokio::time::sleep(Duration::from_millis(500)).await;
            let done = counters.results.load(Ordering::Relaxed) - r0;
            samples.push((done as f64, rss_mb(pid, "VmRSS:")));
            file_max = file_max.max(std::fs::metadata(data_dir.join("jobs.redb")).map_or(0, |m| m.len()));
            if last_print.elapsed() > Duration::from_secs(30) {
                last_print = Instant::now();
                let s = t0.elapsed().as_secs_f64();
                let cpu = cpu_s(&pid.to_string());
                println!(
                    "  {s:7.1} s: {done} results ({:.0}/s), coordinator RSS {:.1} MB, CPU {:.2} cores ({:.1} µs per \
                     result since the last line), store {:.1} MB, {} jobs held",
                    done as f64 / s,
                    samples.last().unwrap().1,
                    (cpu - cc0) / s,
                    (cpu - at_print.0) / (done - at_print.1).max(1) as f64 * 1e6,
                    file_max as f64 / 1e6,
                    held.load(Ordering::Relaxed)
                );
                at_print = (cpu, done);
            }
            assert!(failed.lock().unwrap().is_empty(), "jobs failed: {:?}", failed.lock().unwrap());
            if done >= k.results {
                break;
            }
        }
        let wall = t0.elapsed().as_secs_f64();
        let (cc1, bc1, m1) = (cpu_s(&pid.to_string()), cpu_s("self"), machine_jiffies());
        let threads1 = cpu_by_thread(pid);
        let threads: Vec<f64> = threads1.iter().zip(threads0).map(|(b, a)| b - a).collect();
        counters.recording.store(false, Ordering::Relaxed);
        let done = counters.results.load(Ordering::Relaxed) - r0;
        let simulated = counters.simulated.load(Ordering::Relaxed) - sim0;
        let mean_sim_ms =
            (counters.simulated_us.load(Ordering::Relaxed) - simus0) as f64 / simulated.max(1) as f64 / 1e3;
        let polls = counters.polls.load(Ordering::Relaxed) - polls0;
        let empty = counters.empty_polls.load(Ordering::Relaxed) - empty0;
        let peak = rss_mb(pid, "VmHWM:");
        let jobs_submitted = submitted.load(Ordering::Relaxed);
        Measured {
            wall,
            done,
            coord_cpu: cc1 - cc0,
            bench_cpu: bc1 - bc0,
            machine_busy: (m1.0 - m0.0) / (m1.1 - m0.1),
            samples,
            peak,
            file_max,
            mean_sim_ms,
            polls,
            empty,
            jobs_submitted,
            threads,
        }
    });
    // SIGKILL with the jobs running, as a crash would, and read what the store holds.
    let _ = Command::new("kill").args(["-9", &pid.to_string()]).status();
    let _ = coordinator.child.wait();
    drop(rt);
    let store = store_size(&data_dir.join("jobs.redb"));
    let lease = counters.lease_to_ack.lock().unwrap();
    let trip = counters.round_trip.lock().unwrap();
    let rate = m.done as f64 / m.wall;
    let half: Vec<(f64, f64)> =
        m.samples.iter().filter(|s| s.0 >= m.done as f64 / 2.0).map(|s| (s.0 / 1e6, s.1)).collect();
    let rss_slope = if half.len() >= 3 { slope(&half) } else { f64::NAN };
    let rss_at =
        |f: f64| m.samples.iter().find(|s| s.0 >= f * m.done as f64).or(m.samples.last()).map_or(f64::NAN, |s| s.1);
    let errors = counters.errors.load(Ordering::Relaxed);
    let registrations = counters.registrations.load(Ordering::Relaxed);

    println!();
    println!(
        "| capacity ({} slots over {} connections, {} ms simulations, 2 cores) | value |",
        k.slots,
        k.connections,
        k.sim.as_millis()
    );
    println!("|---|---|");
    println!(
        "| jobs | {} running at once, {} on {} parameter(s), {} evaluations each; {} submitted in all |",
        k.jobs, k.optimizer, k.parameters, k.fevals, m.jobs_submitted
    );
    if k.sim.is_zero() {
        println!(
            "| sustained results | {rate:.0}/s over {:.1} s ({} results; answered at once: the ceiling) |",
            m.wall, m.done
        );
    } else {
        println!(
            "| sustained results | {rate:.0}/s over {:.1} s ({} results): {:.1} % of the ideal {ideal:.0}/s; \
             {:.1} % of slots / mean simulated time ({:.2} ms) |",
            m.wall,
            m.done,
            100.0 * rate / ideal,
            100.0 * rate / (k.slots as f64 / (m.mean_sim_ms / 1e3)),
            m.mean_sim_ms
        );
    }
    println!(
        "| lease to acknowledged result, p50 / p99 | {:.1} / {:.1} ms |",
        quantile(&lease, 0.5),
        quantile(&lease, 0.99)
    );
    println!(
        "| poll round trip carrying results, p50 / p99 | {:.2} / {:.2} ms ({} polls, {:.2} results per poll, \
         {:.1} % without a point) |",
        quantile(&trip, 0.5),
        quantile(&trip, 0.99),
        m.polls,
        m.done as f64 / m.polls.max(1) as f64,
        100.0 * m.empty as f64 / m.polls.max(1) as f64
    );
    println!(
        "| coordinator CPU | {:.1} µs per result, {:.2} cores |",
        1e6 * m.coord_cpu / m.done as f64,
        m.coord_cpu / m.wall
    );
    println!(
        "| coordinator CPU by thread: store writer / tokio runtime (scheduler, gRPC) / other | {:.1} / {:.1} / {:.1} µs per result |",
        1e6 * m.threads[0] / m.done as f64,
        1e6 * m.threads[1] / m.done as f64,
        1e6 * m.threads[2] / m.done as f64
    );
    println!(
        "| CPU of the simulated slots (this process) / machine busy | {:.2} cores / {:.0} % of 2 cores |",
        m.bench_cpu / m.wall,
        100.0 * m.machine_busy
    );
    println!(
        "| coordinator RSS at 0 / 50 / 100 % of the results; peak | {:.1} / {:.1} / {:.1} MB; {:.1} MB |",
        rss_at(0.0),
        rss_at(0.5),
        rss_at(1.0),
        m.peak
    );
    println!("| RSS slope over the second half | {rss_slope:+.2} MB per million results |");
    println!(
        "| store file: largest during the run / at the kill | {:.1} / {:.1} MB |",
        m.file_max as f64 / 1e6,
        store.file as f64 / 1e6
    );
    println!(
        "| journal at the kill | {} points in {} blocks: {:.1} bytes per point in redb's pages ({:.1} stored) |",
        store.journal_points,
        store.journal_blocks,
        store.journal_bytes as f64 / store.journal_points.max(1) as f64,
        store.journal_stored as f64 / store.journal_points.max(1) as f64
    );
    println!(
        "| job states at the kill | {} states, {:.1} MB in redb's pages |",
        store.states,
        store.states_bytes as f64 / 1e6
    );
    println!("| failed RPCs of the slots (retried) / registrations | {errors} / {registrations} |");
    let logs = std::fs::read_to_string(coordinator.dir.path().join("coordinator.log")).unwrap_or_default();
    let warnings: Vec<&str> = logs.lines().filter(|l| l.contains("WARN") || l.contains("ERROR")).collect();
    if !warnings.is_empty() {
        println!("\n{} coordinator warnings or errors (first 10):", warnings.len());
        for l in warnings.iter().take(10) {
            println!("  {l}");
        }
    }
}
