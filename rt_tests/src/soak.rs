//! The soak: `e2e` with a report every `report_every_s` (`vpsom-rt-tests soak` sets 60 s): per
//! interval the LBV cycles and misses (by cause), the GBV rounds (count, p50, max) and the RSS of
//! every process of the pipeline (launcher, each node) and of the harness, from
//! `/proc/<pid>/status` (the harness keeps every sample for its percentiles, so its growth is
//! reported but is no budget). RSS growth per process = median RSS over the last third of the
//! intervals after `rss_warmup_s` / median over the first third − 1 (sessions restart their
//! processes, so a per-minute figure mixes session phases; medians over several minutes compare
//! like with like).

use crate::report::BudgetCheck;
use std::collections::BTreeMap;

/// What one interval accumulated.
#[derive(Debug, Default)]
pub struct Interval {
    /// LBV cycles.
    pub cycles: u64,
    /// LBV misses by cause name.
    pub misses: BTreeMap<String, u64>,
    /// GBV round times, ns.
    pub gbv: Vec<u64>,
}

/// One report row.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Row {
    /// Measured time at the end of the interval, s.
    pub t_s: f64,
    /// Session (1-based) running at the end of the interval.
    pub session: u32,
    /// LBV cycles in the interval.
    pub cycles: u64,
    /// LBV misses in the interval, by cause.
    pub misses: BTreeMap<String, u64>,
    /// GBV rounds finished in the interval.
    pub gbv_rounds: usize,
    /// Their median and largest time, ms.
    pub gbv_p50_ms: f64,
    /// Largest GBV round, ms.
    pub gbv_max_ms: f64,
    /// RSS per process (role), kB.
    pub rss_kb: BTreeMap<String, u64>,
}

impl Interval {
    /// Close the interval into a row (and start a new one).
    pub fn close(&mut self, t_s: f64, session: u32, rss_kb: BTreeMap<String, u64>) -> Row {
        let mut gbv = std::mem::take(&mut self.gbv);
        gbv.sort_unstable();
        let ms = |v: Option<&u64>| v.map_or(0.0, |x| *x as f64 * 1e-6);
        let row = Row {
            t_s,
            session,
            cycles: self.cycles,
            misses: std::mem::take(&mut self.misses),
            gbv_rounds: gbv.len(),
            gbv_p50_ms: ms(gbv.get(gbv.len() / 2)),
            gbv_max_ms: ms(gbv.last()),
            rss_kb,
        };
        self.cycles = 0;
        row
    }
}

/// `VmRSS` of `pid`, kB.
fn rss_kb(pid: u32) -> Option<u64> {
    let s = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    s.lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.split_whitespace().next())
        .and_then(|v| v.parse().ok())
}

/// RSS of the pipeline whose launcher is `launcher` (the launcher and each `vpsom node <role>`
/// child), and of this harness, kB.
pub fn pipeline_rss(launcher: u32) -> BTreeMap<String, u64> {
    let mut out = BTreeMap::new();
    if let Some(r) = rss_kb(std::process::id()) {
        out.insert("harness".to_string(), r);
    }
    if let Some(r) = rss_kb(launcher) {
        out.insert("launcher".to_string(), r);
    }
    let Ok(dir) = std::fs::read_dir("/proc") else {
        return out;
    };
    for e in dir.flatten() {
        let Ok(pid) = e.file_name().to_string_lossy().parse::<u32>() else {
            continue;
        };
        let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) else {
            continue;
        };
        let ppid = stat
            .rsplit_once(')')
            .and_then(|(_, rest)| rest.split_whitespace().nth(1))
            .and_then(|p| p.parse::<u32>().ok());
        if ppid != Some(launcher) {
            continue;
        }
        let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
        let args: Vec<&[u8]> = cmdline.split(|b| *b == 0).collect();
        let role = args
            .windows(2)
            .find(|w| w[0] == b"node")
            .map(|w| String::from_utf8_lossy(w[1]).to_string());
        if let (Some(role), Some(r)) = (role, rss_kb(pid)) {
            out.insert(role, r);
        }
    }
    out
}

/// RSS growth of one process over the soak.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Growth {
    /// Process (role).
    pub process: String,
    /// Median RSS over the first third of the intervals after the warm-up, kB.
    pub early_kb: u64,
    /// Median over the last third, kB.
    pub late_kb: u64,
    /// `late / early − 1`, %.
    pub growth_pct: f64,
}

fn median(mut v: Vec<u64>) -> u64 {
    v.sort_unstable();
    v.get(v.len() / 2).copied().unwrap_or(0)
}

/// RSS growth per process over the rows at or after `warmup_s`; empty with fewer than 3 rows.
pub fn growth(rows: &[Row], warmup_s: f64) -> Vec<Growth> {
    let after: Vec<&Row> = rows.iter().filter(|r| r.t_s >= warmup_s).collect();
    if after.len() < 3 {
        return Vec::new();
    }
    let third = after.len() / 3;
    let (early, late) = (&after[..third], &after[after.len() - third..]);
    let names: std::collections::BTreeSet<&String> =
        after.iter().flat_map(|r| r.rss_kb.keys()).collect();
    names
        .into_iter()
        .filter_map(|n| {
            let pick = |rs: &[&Row]| -> Vec<u64> {
                rs.iter().filter_map(|r| r.rss_kb.get(n).copied()).collect()
            };
            let (e, l) = (pick(early), pick(late));
            if e.is_empty() || l.is_empty() {
                return None;
            }
            let (early_kb, late_kb) = (median(e), median(l));
            Some(Growth {
                process: n.clone(),
                early_kb,
                late_kb,
                growth_pct: (late_kb as f64 / early_kb.max(1) as f64 - 1.0) * 100.0,
            })
        })
        .collect()
}

/// The soak's Markdown section: the per-interval table and the RSS growth.
pub fn markdown(rows: &[Row], growth: &[Growth], warmup_s: f64) -> String {
    let procs: std::collections::BTreeSet<&String> =
        rows.iter().flat_map(|r| r.rss_kb.keys()).collect();
    let mut md = String::from(
        "\n## Soak: every interval\n\n| t s | session | LBV cycles | misses (causes) | GBV rounds | GBV p50 / max ms |",
    );
    for p in &procs {
        md += &format!(" RSS {p} MB |");
    }
    md += "\n|---|---|---|---|---|---|";
    md += &"---|".repeat(procs.len());
    md += "\n";
    for r in rows {
        let misses: u64 = r.misses.values().sum();
        let causes: Vec<String> = r.misses.iter().map(|(c, n)| format!("{c} {n}")).collect();
        md += &format!(
            "| {:.0} | {} | {} | {misses}{} | {} | {:.0} / {:.0} |",
            r.t_s,
            r.session,
            r.cycles,
            if causes.is_empty() {
                String::new()
            } else {
                format!(" ({})", causes.join(", "))
            },
            r.gbv_rounds,
            r.gbv_p50_ms,
            r.gbv_max_ms
        );
        for p in &procs {
            md += &match r.rss_kb.get(*p) {
                Some(kb) => format!(" {:.1} |", *kb as f64 / 1024.0),
                None => " - |".into(),
            };
        }
        md += "\n";
    }
    if growth.is_empty() {
        md += &format!(
            "\nRSS growth: fewer than 3 intervals after the {warmup_s} s warm-up; not computed.\n"
        );
    } else {
        md += &format!(
            "\nRSS growth after the {warmup_s} s warm-up (median of the last third of the \
             intervals over the median of the first third):\n\n| process | early MB | late MB | growth |\n|---|---|---|---|\n"
        );
        for g in growth {
            md += &format!(
                "| {} | {:.1} | {:.1} | {:+.1} % |\n",
                g.process,
                g.early_kb as f64 / 1024.0,
                g.late_kb as f64 / 1024.0,
                g.growth_pct
            );
        }
    }
    md
}

/// The budget check of the RSS growth of every pipeline process (none without a growth
/// figure). The harness is reported, not checked: it keeps every sample in memory for the
/// percentiles, so it grows with the run by design.
pub fn checks(growth: &[Growth], max_pct: f64) -> Vec<BudgetCheck> {
    growth
        .iter()
        .filter(|g| g.process != "harness")
        .map(|g| {
            BudgetCheck::at_most(
                format!("soak_rss_growth_pct ({})", g.process),
                g.growth_pct,
                max_pct,
                "%",
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(t_s: f64, rss: u64) -> Row {
        Row {
            t_s,
            session: 1,
            cycles: 1,
            misses: BTreeMap::new(),
            gbv_rounds: 0,
            gbv_p50_ms: 0.0,
            gbv_max_ms: 0.0,
            rss_kb: [("mapper".to_string(), rss)].into(),
        }
    }

    #[test]
    fn growth_compares_medians_of_the_first_and_last_thirds_after_warm_up() {
        // Warm-up row (ignored), then 6 rows: first third 100, 104; last third 106, 102.
        let rows: Vec<Row> = [
            (30.0, 10),
            (60.0, 100),
            (120.0, 104),
            (180.0, 500),
            (240.0, 1),
            (300.0, 106),
            (360.0, 102),
        ]
        .iter()
        .map(|&(t, r)| row(t, r))
        .collect();
        let g = growth(&rows, 60.0);
        assert_eq!(g.len(), 1);
        // Medians (upper of two): early 104, late 106 → +1.92 %.
        assert_eq!((g[0].early_kb, g[0].late_kb), (104, 106));
        assert!((g[0].growth_pct - (106.0 / 104.0 - 1.0) * 100.0).abs() < 1e-9);
        assert!(growth(&rows[..3], 60.0).is_empty());
    }

    #[test]
    fn an_interval_closes_into_a_row_and_restarts() {
        let mut i = Interval {
            cycles: 7,
            gbv: vec![3_000_000, 1_000_000, 2_000_000],
            misses: [("late-wakeup".to_string(), 2)].into(),
        };
        let r = i.close(60.0, 2, BTreeMap::new());
        assert_eq!(
            (r.cycles, r.gbv_rounds, r.gbv_p50_ms, r.gbv_max_ms),
            (7, 3, 2.0, 3.0)
        );
        assert_eq!(r.misses["late-wakeup"], 2);
        assert_eq!((i.cycles, i.gbv.len(), i.misses.len()), (0, 0, 0));
    }
}
