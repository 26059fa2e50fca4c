//! The coordinator's Prometheus metrics. The scheduler, which owns every job and worker, keeps
//! them: counters as results arrive, gauges from its state on every tick. The `fmucal` binary
//! serves the registry they are registered in (`fmucal coordinator --metrics-listen ADDR`,
//! `GET /metrics`). Names follow the Prometheus conventions (base units, `_total` counters):
//!
//! | metric | type | what |
//! |---|---|---|
//! | `fmucal_jobs{state}` | gauge | jobs by state: running, succeeded, failed, cancelled |
//! | `fmucal_points_queued` | gauge | points of running jobs waiting for a worker |
//! | `fmucal_points_leased` | gauge | points out on workers |
//! | `fmucal_workers` | gauge | live (registered, heartbeating) workers |
//! | `fmucal_worker_slots` | gauge | their evaluation slots |
//! | `fmucal_evaluations_total` | counter | results received from workers (evaluations per second: `rate()`) |
//! | `fmucal_failed_evaluations_total` | counter | those whose simulation failed |
//! | `fmucal_ignored_results_total` | counter | results for points never leased to their worker (forged, or a worker's bug), and those past a poll's cap (one per point its worker holds): not told |
//! | `fmucal_late_results_total` | counter | results for points taken back from their worker (its job ended, the point timed out, the worker expired) or sent again: normal, not told |
//! | `fmucal_refused_results_total` | counter | results that cannot be true (a negative or NaN sum of squares, a wrong number of residuals): the point is tried again |
//! | `fmucal_evaluation_latency_seconds` | histogram | from a point's lease to its result |

use std::time::Duration;

use prometheus_client::metrics::counter::Counter;
use prometheus_client::metrics::family::Family;
use prometheus_client::metrics::gauge::Gauge;
use prometheus_client::metrics::histogram::{Histogram, exponential_buckets};
use prometheus_client::registry::Registry;

/// A job state's label.
type StateLabel = [(&'static str, &'static str); 1];

/// The job states `fmucal_jobs` counts, by their label value.
pub const JOB_STATES: [&str; 4] = ["running", "succeeded", "failed", "cancelled"];

/// Handles on the coordinator's metrics (cheap to clone: each is shared).
#[derive(Debug, Clone)]
pub struct CoordinatorMetrics {
    jobs: Family<StateLabel, Gauge>,
    points_queued: Gauge,
    points_leased: Gauge,
    workers: Gauge,
    slots: Gauge,
    evaluations: Counter,
    failed_evaluations: Counter,
    ignored_results: Counter,
    late_results: Counter,
    refused_results: Counter,
    latency: Histogram,
}

/// What the gauges show, counted by the scheduler.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct Gauges {
    /// Jobs by state, in the order of [`JOB_STATES`].
    pub jobs: [i64; 4],
    pub points_queued: i64,
    pub points_leased: i64,
    pub workers: i64,
    pub slots: i64,
}

impl CoordinatorMetrics {
    /// Registers the metrics in `registry`.
    pub fn register(registry: &mut Registry) -> Self {
        let m = CoordinatorMetrics {
            jobs: Family::default(),
            points_queued: Gauge::default(),
            points_leased: Gauge::default(),
            workers: Gauge::default(),
            slots: Gauge::default(),
            evaluations: Counter::default(),
            failed_evaluations: Counter::default(),
            ignored_results: Counter::default(),
            late_results: Counter::default(),
            refused_results: Counter::default(),
            // 1 ms to about 9 minutes.
            latency: Histogram::new(exponential_buckets(0.001, 2.0, 20)),
        };
        registry.register("fmucal_jobs", "Jobs by state", m.jobs.clone());
        let gauges = [
            ("fmucal_points_queued", "Points of running jobs waiting for a worker", &m.points_queued),
            ("fmucal_points_leased", "Points out on workers", &m.points_leased),
            ("fmucal_workers", "Live workers", &m.workers),
            ("fmucal_worker_slots", "Evaluation slots of the live workers", &m.slots),
        ];
        for (name, help, gauge) in gauges {
            registry.register(name, help, gauge.clone());
        }
        let counters = [
            ("fmucal_evaluations", "Results received from workers", &m.evaluations),
            ("fmucal_failed_evaluations", "Results whose simulation failed", &m.failed_evaluations),
            (
                "fmucal_ignored_results",
                "Results for points never leased to their worker, or past a poll's cap, not told",
                &m.ignored_results,
            ),
            (
                "fmucal_late_results",
                "Results for points taken back from their worker (job ended, timed out, worker expired), not told",
                &m.late_results,
            ),
            (
                "fmucal_refused_results",
                "Results that cannot be true (negative or NaN sum of squares, wrong residual count), tried again",
                &m.refused_results,
            ),
        ];
        for (name, help, counter) in counters {
            registry.register(name, help, counter.clone());
        }
        registry.register(
            "fmucal_evaluation_latency_seconds",
            "Time from a point's lease to its result",
            m.latency.clone(),
        );
        for state in JOB_STATES {
            let _ = m.jobs.get_or_create(&[("state", state)]);
        }
        m
    }

    /// A worker's result for a point leased `latency` ago (`None`: not known).
    pub fn result(&self, failed: bool, latency: Option<Duration>) {
        self.evaluations.inc();
        if failed {
            self.failed_evaluations.inc();
        }
        if let Some(l) = latency {
            self.latency.observe(l.as_secs_f64());
        }
    }

    /// A result for a point never leased to the worker that sent it, or past its poll's cap,
    /// ignored.
    pub fn ignored_result(&self) {
        self.ignored_results.inc();
    }

    /// A late result, for a point taken back from the worker that sent it, ignored.
    pub fn late_result(&self) {
        self.late_results.inc();
    }

    /// A result that cannot be true, refused.
    pub fn refused_result(&self) {
        self.refused_results.inc();
    }

    /// Sets the gauges.
    pub fn set(&self, g: &Gauges) {
        for (state, n) in JOB_STATES.iter().zip(g.jobs) {
            self.jobs.get_or_create(&[("state", state)]).set(n);
        }
        self.points_queued.set(g.points_queued);
        self.points_leased.set(g.points_leased);
        self.workers.set(g.workers);
        self.slots.set(g.slots);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_registry_reads_in_the_prometheus_text_format() {
        let mut registry = Registry::default();
        let m = CoordinatorMetrics::register(&mut registry);
        m.set(&Gauges { jobs: [1, 2, 0, 3], points_queued: 7, points_leased: 4, workers: 2, slots: 5 });
        m.result(false, Some(Duration::from_millis(3)));
        m.result(true, None);
        m.ignored_result();
        m.late_result();
        m.late_result();
        m.refused_result();
        let mut text = String::new();
        prometheus_client::encoding::prometheus_text::encode(&mut text, &registry).unwrap();
        for line in [
            "fmucal_jobs{state=\"running\"} 1",
            "fmucal_jobs{state=\"cancelled\"} 3",
            "fmucal_jobs{state=\"failed\"} 0",
            "fmucal_points_queued 7",
            "fmucal_points_leased 4",
            "fmucal_workers 2",
            "fmucal_worker_slots 5",
            "fmucal_evaluations_total 2",
            "fmucal_failed_evaluations_total 1",
            "fmucal_ignored_results_total 1",
            "fmucal_late_results_total 2",
            "fmucal_refused_results_total 1",
            "fmucal_evaluation_latency_seconds_count 1",
            "fmucal_evaluation_latency_seconds_bucket{le=\"0.004\"} 1",
            "fmucal_evaluation_latency_seconds_bucket{le=\"0.002\"} 0",
            "# TYPE fmucal_evaluations_total counter",
        ] {
            assert!(text.lines().any(|l| l == line), "{line:?} missing from\n{text}");
        }
    }
}
