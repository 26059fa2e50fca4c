//! The worker's Prometheus metrics, kept by its slots as they evaluate points. The `fmucal`
//! binary serves the registry they are registered in (`fmucal worker --metrics-listen ADDR`,
//! `GET /metrics`):
//!
//! | metric | type | what |
//! |---|---|---|
//! | `fmucal_worker_evaluations_total` | counter | points evaluated (handed back unevaluated ones not counted) |
//! | `fmucal_worker_failed_evaluations_total` | counter | those whose simulation failed |
//! | `fmucal_worker_simulation_seconds` | histogram | wall time of one evaluation (its `_sum` is the total) |

use std::time::Duration;

use prometheus_client::metrics::counter::Counter;
use prometheus_client::metrics::histogram::{Histogram, exponential_buckets};
use prometheus_client::registry::Registry;

/// Handles on the worker's metrics (cheap to clone: each is shared).
#[derive(Debug, Clone)]
pub struct WorkerMetrics {
    evaluations: Counter,
    failed: Counter,
    simulation: Histogram,
}

impl WorkerMetrics {
    /// Registers the metrics in `registry`.
    pub fn register(registry: &mut Registry) -> Self {
        let m = WorkerMetrics {
            evaluations: Counter::default(),
            failed: Counter::default(),
            // 1 ms to about 9 minutes.
            simulation: Histogram::new(exponential_buckets(0.001, 2.0, 20)),
        };
        registry.register("fmucal_worker_evaluations", "Points evaluated", m.evaluations.clone());
        registry.register("fmucal_worker_failed_evaluations", "Points whose simulation failed", m.failed.clone());
        registry.register("fmucal_worker_simulation_seconds", "Wall time of one evaluation", m.simulation.clone());
        m
    }

    /// One evaluated point.
    pub fn evaluated(&self, failed: bool, wall: Duration) {
        self.evaluations.inc();
        if failed {
            self.failed.inc();
        }
        self.simulation.observe(wall.as_secs_f64());
    }
}
