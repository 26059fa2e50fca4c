//! FMU runtime benchmarks. Run with `cargo bench --bench runtime -- [--json FILE]`;
//! `bench/runtime.sh` runs this and FMPy on the same FMUs and grids and prints the ratios.
//!
//! Measures (median of repeated runs, wall time):
//! - `furuta_me_1ms`: Furuta, Model Exchange, 40 s, 1 ms output grid, rtol 1e-6, fresh instance;
//! - `furuta_fmi3_me_1ms`: the same for the FMI 3.0 build of Furuta (`Fixture::FurutaFmi3`, same
//!   C source); its path is written to the JSON (`furuta_fmi3_fmu`) for FMPy to time the same file;
//! - `bouncing_ball_me_1ms`: bouncing ball, Model Exchange, 3 s, 1 ms grid, rtol 1e-6;
//! - `warm_over_fresh`: (fmi2Reset + simulate) on a warm instance divided by simulating on a
//!   just-instantiated one (instantiation not timed), Furuta ME 40 s, 10 ms grid;
//! - `rss_growth_mb`: resident memory growth over 10,000 reset-and-simulate cycles of one
//!   instance (bouncing ball ME, 3 s, 10 ms grid), after 200 warm-up cycles.

use std::time::Instant;

use fmucal_shared::fmu::{Fmu, Interface};
use fmucal_shared::sim::{OutputTimes, SimSpec, Simulator, simulate};

fn spec(stop: f64, dt: f64) -> SimSpec {
    SimSpec {
        interface: Some(Interface::ModelExchange),
        stop_time: Some(stop),
        output_times: Some(OutputTimes::Interval(dt)),
        tolerance: Some(1e-6),
        ..Default::default()
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn time_fresh(fmu: &Fmu, spec: &SimSpec, repeat: usize) -> f64 {
    median(
        (0..repeat)
            .map(|_| {
                let t = Instant::now();
                simulate(fmu, spec).expect("simulate");
                t.elapsed().as_secs_f64()
            })
            .collect(),
    )
}

fn rss_kb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| s.lines().find(|l| l.starts_with("VmRSS:")).map(|l| l.to_owned()))
        .and_then(|l| l.split_whitespace().nth(1).and_then(|x| x.parse().ok()))
        .unwrap_or(f64::NAN)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let json_out = args.iter().position(|a| a == "--json").and_then(|i| args.get(i + 1)).cloned();
    let load = |name: &str| Fmu::load(&fmucal_models::example(name).unwrap()).expect("load example");
    let furuta = load("furuta");
    let ball = load("bouncing-ball");
    let furuta_fmi3_path = fmucal_models::Fixture::FurutaFmi3.path();
    let furuta_fmi3 = Fmu::load(&furuta_fmi3_path).expect("load FurutaFmi3 fixture");

    let furuta_me = time_fresh(&furuta, &spec(40.0, 1e-3), 7);
    let furuta_fmi3_me = time_fresh(&furuta_fmi3, &spec(40.0, 1e-3), 7);
    let ball_me = time_fresh(&ball, &spec(3.0, 1e-3), 21);

    let warm_spec = spec(40.0, 1e-2);
    let mut ratios = vec![];
    let mut warm = Simulator::new(&furuta, Some(Interface::ModelExchange)).unwrap();
    warm.run(&warm_spec).unwrap();
    for _ in 0..15 {
        let mut fresh = Simulator::new(&furuta, Some(Interface::ModelExchange)).unwrap();
        let t = Instant::now();
        fresh.run(&warm_spec).unwrap();
        let fresh_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        warm.run(&warm_spec).unwrap();
        ratios.push(t.elapsed().as_secs_f64() / fresh_s);
    }
    let warm_over_fresh = median(ratios);

    let rss_spec = SimSpec { output_times: Some(OutputTimes::Interval(1e-2)), ..spec(3.0, 1e-2) };
    let mut sim = Simulator::new(&ball, Some(Interface::ModelExchange)).unwrap();
    for _ in 0..200 {
        sim.run(&rss_spec).unwrap();
    }
    let before = rss_kb();
    let t = Instant::now();
    for _ in 0..10_000 {
        sim.run(&rss_spec).unwrap();
    }
    let cycles_s = t.elapsed().as_secs_f64();
    let rss_growth_mb = (rss_kb() - before) / 1024.0;

    println!("furuta_me_1ms_s          {furuta_me:.5}");
    println!("furuta_fmi3_me_1ms_s     {furuta_fmi3_me:.5}");
    println!("bouncing_ball_me_1ms_s   {ball_me:.5}");
    println!("warm_over_fresh          {warm_over_fresh:.3}");
    println!("rss_growth_mb            {rss_growth_mb:.3}  (10,000 cycles in {cycles_s:.1} s)");
    if let Some(path) = json_out {
        let json = serde_json::json!({
            "furuta_me_1ms_s": furuta_me,
            "furuta_fmi3_me_1ms_s": furuta_fmi3_me,
            "furuta_fmi3_fmu": furuta_fmi3_path,
            "bouncing_ball_me_1ms_s": ball_me,
            "warm_over_fresh": warm_over_fresh,
            "rss_growth_mb": rss_growth_mb,
            "rss_cycles_s": cycles_s,
        });
        std::fs::write(&path, json.to_string()).expect("write json");
    }
}
