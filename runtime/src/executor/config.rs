//! `[executor]` configuration: [`ExecutorConfig`], the enums it selects from, and its range check.

use crate::config::{Checker, ConfigError};
use crate::pool::PoolConfig;
use serde::Deserialize;

/// Scheduling policy requested for an executor thread.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SchedPolicy {
    /// `SCHED_FIFO` at `priority` (falls back to `nice` if refused).
    Fifo,
    /// `SCHED_OTHER` at `nice`.
    Other,
}

/// What happens after a missed deadline (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MissPolicy {
    /// Skip the next release, then resume at the first future release.
    Skip,
    /// Run once immediately (late), flag `previous_missed`, resume the grid.
    Hold,
}

/// What escalation does besides being reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EscalateAction {
    /// Keep running; the state is `Escalated` and the body sees `Cycle::escalated`.
    Report,
    /// Stop the executor; `join` reports `StopReason::Escalated`.
    Stop,
}

/// Which cycles produce a [`DeadlineEvent`](shm_types::DeadlineEvent) on the event sink.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EventTrace {
    /// Every cycle.
    All,
    /// Only cycles that missed their deadline.
    Misses,
    /// None.
    None,
}

/// `[executor]` section: defaults for every periodic executor (the period comes from the node's
/// rate), and `[executor.pool]` for the low-priority worker pool.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExecutorConfig {
    /// Requested policy.
    pub policy: SchedPolicy,
    /// `SCHED_FIFO` priority, 1..=98 (99 is left to kernel watchdogs).
    pub priority: i32,
    /// Nice value for `other`, and the fallback when FIFO is refused (-20..=19; a negative value
    /// needs privileges and is itself logged and dropped if refused).
    pub nice: i32,
    /// Lock the process's memory (`mlockall(MCL_CURRENT | MCL_FUTURE)`) when FIFO is granted.
    pub mlockall: bool,
    /// CPUs to pin the thread to; empty = no pinning.
    pub cpus: Vec<usize>,
    /// Sleep until this long before each release, then spin (µs); 0 = pure sleep.
    pub spin_margin_us: u64,
    /// While the process runs, hold `/dev/cpu_dma_latency` at this many µs (no deep idle
    /// states; cyclictest does the same by default); -1 = leave the system's setting.
    pub cpu_dma_latency_us: i32,
    /// CPU of the backup waker (-1 = none): a second thread at the executor's priority that
    /// wakes the executor thread on this CPU when its own timer has not woken it
    /// `backup_delay_us` after a release (a VM stalls one virtual CPU at a time). Needs `cpus`
    /// set, without this CPU, and the real clock.
    pub backup_cpu: i32,
    /// How long after a release the backup waker steps in, µs.
    pub backup_delay_us: u64,
    /// Budget as a fraction of the period, (0, 1]: a cycle misses if it ends after release+budget.
    pub budget_fraction: f64,
    /// Policy after a miss.
    pub miss_policy: MissPolicy,
    /// Escalate after this many consecutive misses (0 = never).
    pub escalate_after: u32,
    /// What escalation does.
    pub on_escalate: EscalateAction,
    /// Which cycles are traced as `DeadlineEvent`s.
    pub trace: EventTrace,
    /// Worker pool settings (`[executor.pool]`).
    pub pool: PoolConfig,
}

impl Default for ExecutorConfig {
    /// The `[executor]` section of the built-in `config/runtime.toml`.
    fn default() -> Self {
        crate::config::RUNTIME_DEFAULTS.section("executor")
    }
}

impl ExecutorConfig {
    /// Range-check the `[executor]` section and `[executor.pool]`.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        let c = &c.at("executor");
        settings::ranges!(c, self, {
            priority: within(1, 98),
            nice: within(-20, 19),
        });
        for &cpu in &self.cpus {
            let key = settings::key!(c, cpus);
            c.require(cpu < 1024, &key, cpu, "must be a CPU index below 1024")?;
        }
        settings::ranges!(c, self, {
            spin_margin_us: within(0, 100_000),
            cpu_dma_latency_us: require(
                (-1..=10_000_000).contains(&self.cpu_dma_latency_us),
                "must be in [-1, 10000000] (-1 = leave the system setting)",
            ),
            backup_cpu: require(
                (-1..1024).contains(&self.backup_cpu),
                "must be a CPU index below 1024, or -1 for none",
            ),
        });
        if let Ok(cpu) = usize::try_from(self.backup_cpu) {
            settings::ranges!(c, self, {
                backup_cpu: require(
                    !self.cpus.is_empty() && !self.cpus.contains(&cpu),
                    &format!(
                        "needs {} set to the executor's own CPUs, without the backup CPU",
                        settings::key!(c, cpus)
                    ),
                ),
            });
        }
        settings::ranges!(c, self, {
            backup_delay_us: within(10, 1_000_000),
            budget_fraction: require(
                self.budget_fraction.is_finite()
                    && self.budget_fraction > 0.0
                    && self.budget_fraction <= 1.0,
                "must be in (0, 1]",
            ),
            escalate_after: require(
                self.escalate_after <= 1_000_000,
                "must be in [0, 1000000] (0 = never)",
            ),
            pool: section,
        });
        Ok(())
    }
}
