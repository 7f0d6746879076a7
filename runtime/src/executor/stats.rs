//! Percentiles: the [`latency_histogram`] every monitor records into, [`Stats`] (percentiles of
//! one histogram) and the executor's end-of-run [`Summary`].

use super::monitor::DeadlineMonitor;
use super::run::StopReason;
use super::sched::SchedReport;
use hdrhistogram::Histogram;
use serde::Serialize;
use std::fmt;

/// Largest value a [`latency_histogram`] records (60 s), and the longest executor period, ns.
pub(super) const HIST_MAX_NS: u64 = 60_000_000_000;

/// A latency histogram: 1 ns .. 60 s, 3 significant digits (what [`DeadlineMonitor`] records
/// into, and what [`Stats::of_samples`] uses).
pub fn latency_histogram() -> Histogram<u64> {
    Histogram::new_with_bounds(1, HIST_MAX_NS, 3).expect("constant histogram bounds are valid")
}

/// Percentiles of one histogram, nanoseconds.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Stats {
    /// Samples.
    pub count: u64,
    /// Smallest.
    pub min: u64,
    /// Mean.
    pub mean: f64,
    /// Median.
    pub p50: u64,
    /// 90th percentile.
    pub p90: u64,
    /// 99th percentile.
    pub p99: u64,
    /// 99.9th percentile.
    pub p999: u64,
    /// Largest.
    pub max: u64,
}

impl Stats {
    /// Percentiles of `h` (all zero if it is empty).
    pub fn of(h: &Histogram<u64>) -> Self {
        if h.is_empty() {
            return Self::default();
        }
        Self {
            count: h.len(),
            min: h.min(),
            mean: h.mean(),
            p50: h.value_at_quantile(0.5),
            p90: h.value_at_quantile(0.9),
            p99: h.value_at_quantile(0.99),
            p999: h.value_at_quantile(0.999),
            max: h.max(),
        }
    }

    /// Percentiles of raw samples, ns, through a [`latency_histogram`] (0 counts as 1 ns,
    /// beyond 60 s as 60 s).
    pub fn of_samples(samples: &[u64]) -> Self {
        let mut h = latency_histogram();
        for &s in samples {
            h.saturating_record(s.max(1));
        }
        Self::of(&h)
    }
}

impl fmt::Display for Stats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "n={} min={:.1}µs p50={:.1}µs p99={:.1}µs p99.9={:.1}µs max={:.1}µs",
            self.count,
            self.min as f64 / 1e3,
            self.p50 as f64 / 1e3,
            self.p99 as f64 / 1e3,
            self.p999 as f64 / 1e3,
            self.max as f64 / 1e3
        )
    }
}

/// What [`ExecutorHandle::join`](super::ExecutorHandle::join) returns.
#[derive(Debug, Clone)]
pub struct Summary {
    /// Thread name.
    pub name: String,
    /// Why it stopped.
    pub reason: StopReason,
    /// Scheduling the thread got.
    pub sched: SchedReport,
    /// Releases skipped (never run) because of misses or overruns.
    pub skipped: u64,
    /// Deadline events that could not be queued (sink full or gone).
    pub events_dropped: u64,
    /// Cycles whose wake-up the backup waker did (the thread's own timer was late).
    pub backup_wakes: u64,
    /// The monitor (counts and histograms).
    pub monitor: DeadlineMonitor,
    /// Lateness percentiles.
    pub lateness: Stats,
    /// Execution-time percentiles.
    pub exec: Stats,
}

impl fmt::Display for Summary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{}: {} cycles, {} misses{} (max {} in a row), {} skipped, {}{} escalations, {:?}, {}",
            self.name,
            self.monitor.cycles(),
            self.monitor.misses(),
            match self.monitor.miss_causes() {
                c if c.is_empty() => c,
                c => format!(" ({c})"),
            },
            self.monitor.max_consecutive(),
            self.skipped,
            match self.sched.backup_cpu {
                Some(_) => format!("{} backup wake-ups, ", self.backup_wakes),
                None => String::new(),
            },
            self.monitor.escalations(),
            self.reason,
            self.sched
        )?;
        writeln!(f, "  lateness {}", self.lateness)?;
        write!(f, "  exec     {}", self.exec)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_of_one_to_thousand_samples() {
        let samples: Vec<u64> = (1..=1000).map(|k| k * 1000).collect();
        let p = Stats::of_samples(&samples);
        assert_eq!(p.count, 1000);
        assert_eq!(p.min, 1000);
        // 3 significant digits: values are exact to within 0.1%.
        for (got, want) in [
            (p.p50, 500_000),
            (p.p90, 900_000),
            (p.p99, 990_000),
            (p.p999, 999_000),
            (p.max, 1_000_000),
        ] {
            assert!(
                (got as f64 - want as f64).abs() <= want as f64 * 1e-3,
                "{got} {want}"
            );
        }
        assert!((p.mean - 500_500.0).abs() <= 500.0, "{}", p.mean);
        assert_eq!(Stats::of_samples(&[]), Stats::default());
        assert_eq!(Stats::of_samples(&[0]).min, 1, "0 ns counts as 1 ns");
    }
}
