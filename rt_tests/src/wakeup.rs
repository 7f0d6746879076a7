//! `wakeup`: cyclictest-style wake-up latency of the runtime's own periodic executor, optionally
//! side by side with Debian's `cyclictest` run with the same settings right after.

use crate::Outcome;
use crate::report::{BudgetCheck, SampleLog, Series, histogram_png};
use crate::settings::{Budgets, WakeupSettings};
use crate::stats::{Stats, columns, ratio, table_header, table_row};
use anyhow::{Context, Result, bail};
use runtime::executor::{Control, Cycle, Executor};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

/// Period of thread `k`, µs.
fn period_us(w: &WakeupSettings, k: usize) -> u64 {
    w.period_us + k as u64 * w.distance_us
}

/// Run the test; `compare` also runs cyclictest.
pub fn run(
    w: &WakeupSettings,
    compare: bool,
    budgets: &Budgets,
    dir: &Path,
    log: &mut SampleLog,
) -> Result<Outcome> {
    // cyclictest only takes whole seconds; use the same duration for both.
    let duration_s = if compare {
        w.duration_s.ceil()
    } else {
        w.duration_s
    };
    // cyclictest ignores -d in histogram mode: all its threads share one period; so do ours.
    let w = &WakeupSettings {
        distance_us: if compare { 0 } else { w.distance_us },
        ..w.clone()
    };
    let (tx, rx) = std::sync::mpsc::channel::<(usize, Vec<u64>)>();
    let mut handles = Vec::new();
    for k in 0..w.threads {
        let mut sched = w.sched.clone();
        if !sched.cpus.is_empty() {
            sched.cpus = vec![sched.cpus[k % sched.cpus.len()]];
        }
        let cfg = sched.executor_config(w.spin_margin_us);
        let period = period_us(w, k);
        let cycles = ((duration_s * 1e6 / period as f64).round() as usize).max(1);
        let tx = tx.clone();
        let h = Executor::builder(&format!("wakeup-{k}"), Duration::from_micros(period))
            .config(&cfg)
            .spawn(move || {
                let mut v: Vec<u64> = Vec::with_capacity(cycles);
                move |c: &Cycle| {
                    v.push(c.wake_ns.saturating_sub(c.release_ns));
                    if v.len() >= cycles {
                        let _ = tx.send((k, std::mem::take(&mut v)));
                        Control::Stop
                    } else {
                        Control::Continue
                    }
                }
            })
            .with_context(|| format!("start wakeup thread {k}"))?;
        handles.push(h);
    }
    drop(tx);
    while !handles.iter().all(|h| h.is_finished()) {
        if crate::interrupted() {
            for h in &handles {
                h.stop();
            }
            bail!("interrupted");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let mut sched_lines = Vec::new();
    for h in handles {
        let s = h.join()?;
        sched_lines.push(format!("{}: {}", s.name, s.sched));
    }
    let mut ours: Vec<Vec<u64>> = vec![Vec::new(); w.threads];
    for (k, v) in rx.try_iter() {
        ours[k] = v;
    }
    for (k, v) in ours.iter().enumerate() {
        for (seq, &l) in v.iter().enumerate() {
            log.record(
                &format!("/wakeup/ours/{k}"),
                seq as u64 * period_us(w, k) * 1000,
                &json!({"seq": seq, "lateness_ns": l}),
            )?;
        }
    }
    let ours_p: Vec<Stats> = ours.iter().map(|v| Stats::of_samples(v)).collect();
    let ours_all: Vec<u64> = ours.iter().flatten().copied().collect();
    let ours_all_p = Stats::of_samples(&ours_all);

    let mut md = format!(
        "# vpsom-rt-tests wakeup\n\n{} thread(s), period {} µs (+{} µs per thread), {:.1} s, \
         policy {} prio {}, cpus {:?}, spin margin {} µs, mlockall {}.\n\nScheduling granted: {}\n\n\
         Lateness = actual − intended wake-up.\n\n",
        w.threads,
        w.period_us,
        w.distance_us,
        duration_s,
        w.sched.policy,
        w.sched.priority,
        w.sched.cpus,
        w.spin_margin_us,
        w.sched.mlockall,
        sched_lines.join("; ")
    );
    md += &table_header(&["source", "thread", "period µs"]);
    for (k, p) in ours_p.iter().enumerate() {
        md += &table_row(
            &[
                "executor".into(),
                k.to_string(),
                period_us(w, k).to_string(),
            ],
            p,
        );
    }
    md += &table_row(&["executor".into(), "all".into(), "-".into()], &ours_all_p);

    let mut checks = Vec::new();
    for (k, p) in ours_p.iter().enumerate() {
        checks.push(BudgetCheck::at_most(
            format!("wakeup_p99_us (thread {k})"),
            p.p99 as f64 / 1e3,
            budgets.wakeup_p99_us,
            "µs",
        ));
    }
    let mut json = json!({
        "settings": w,
        "duration_s": duration_s,
        "sched": sched_lines,
        "ours": {"threads": ours_p, "all": ours_all_p},
    });
    let mut series = vec![Series {
        label: "vpsom executor (all threads)".into(),
        samples: &ours_all,
    }];
    let cyc_samples;
    if compare {
        match cyclictest(w, duration_s, dir)? {
            None => {
                let msg = "cyclictest not found: install it with `sudo apt-get install rt-tests` \
                           (Debian/Ubuntu); comparison skipped";
                eprintln!("{msg}");
                md += &format!("\n**{msg}.**\n");
                json["cyclictest"] = json!({"error": msg});
                cyc_samples = Vec::new();
            }
            Some((threads, cmdline)) => {
                let cyc_p: Vec<Stats> = threads.iter().map(|v| Stats::of_samples(v)).collect();
                cyc_samples = threads.iter().flatten().copied().collect::<Vec<u64>>();
                let cyc_all = Stats::of_samples(&cyc_samples);
                for (k, p) in cyc_p.iter().enumerate() {
                    md += &table_row(
                        &[
                            "cyclictest".into(),
                            k.to_string(),
                            period_us(w, k).to_string(),
                        ],
                        p,
                    );
                }
                md += &table_row(&["cyclictest".into(), "all".into(), "-".into()], &cyc_all);
                md += &format!(
                    "\ncyclictest (1 µs resolution, run right after ours): `{cmdline}`\n\n\
                     Ratio ours / cyclictest (all threads):\n\n| min | p50 | p90 | p99 | p99.9 | max |\n\
                     |---|---|---|---|---|---|\n|"
                );
                let mut ratios = serde_json::Map::new();
                for ((name, a), (_, b)) in columns(&ours_all_p).iter().zip(columns(&cyc_all)) {
                    let r = ratio(*a, b);
                    md += &format!(" {r:.2} |");
                    ratios.insert(name.to_string(), json!(r));
                }
                md += "\n";
                checks.push(BudgetCheck::at_most(
                    "wakeup_vs_cyclictest (p99)",
                    ratio(ours_all_p.p99, cyc_all.p99),
                    budgets.wakeup_vs_cyclictest,
                    "×",
                ));
                checks.push(BudgetCheck::at_most(
                    "wakeup_vs_cyclictest (max)",
                    ratio(ours_all_p.max, cyc_all.max),
                    budgets.wakeup_vs_cyclictest,
                    "×",
                ));
                json["cyclictest"] = json!({
                    "command": cmdline, "threads": cyc_p, "all": cyc_all, "ratio_ours_over_cyclictest": ratios
                });
                for (k, v) in threads.iter().enumerate() {
                    for (seq, &l) in v.iter().enumerate() {
                        log.record(
                            &format!("/wakeup/cyclictest/{k}"),
                            seq as u64,
                            &json!({"bucket_index": seq, "lateness_ns": l}),
                        )?;
                    }
                }
            }
        }
        if !cyc_samples.is_empty() {
            series.push(Series {
                label: "cyclictest (all threads)".into(),
                samples: &cyc_samples,
            });
        }
    }
    histogram_png(&dir.join("wakeup.png"), "wake-up latency", &series)?;
    md += "\n![wake-up latency histogram](wakeup.png)\n";
    Ok(Outcome {
        markdown: md,
        json,
        checks,
        errors: Vec::new(),
    })
}

/// Run cyclictest with `w`'s settings; per-thread samples (ns, 1 µs resolution, histogram
/// overflows recorded at that thread's max) and the command line. `None` if not installed.
fn cyclictest(
    w: &WakeupSettings,
    duration_s: f64,
    dir: &Path,
) -> Result<Option<(Vec<Vec<u64>>, String)>> {
    if !crate::stress::which("cyclictest") {
        return Ok(None);
    }
    let mut args: Vec<String> = vec![
        "-D".into(),
        format!("{}", duration_s as u64),
        "-i".into(),
        w.period_us.to_string(),
        "-d".into(),
        w.distance_us.to_string(),
        "-t".into(),
        w.threads.to_string(),
        "-h".into(),
        w.hist_max_us.to_string(),
    ];
    if w.sched.policy == "fifo" {
        args.extend([
            "-p".into(),
            w.sched.priority.to_string(),
            "--policy=fifo".into(),
        ]);
    } else {
        args.push("--policy=other".into());
    }
    if w.sched.mlockall {
        args.push("-m".into());
    }
    if !w.sched.cpus.is_empty() {
        let list: Vec<String> = w.sched.cpus.iter().map(|c| c.to_string()).collect();
        args.extend(["-a".into(), list.join(",")]);
    }
    let run = Cyclictest::spawn(args, w.threads, &dir.join("cyclictest.txt"))?;
    let cmdline = run.cmdline.clone();
    Ok(Some((run.wait()?, cmdline)))
}

/// A running `cyclictest -q` with a histogram (`-h`), its output going to a file. Killed if
/// dropped while running (an error elsewhere must not leave it behind).
pub struct Cyclictest {
    /// `None` once reaped.
    child: Option<Child>,
    threads: usize,
    out_path: PathBuf,
    /// The command line.
    pub cmdline: String,
}

impl Cyclictest {
    /// Start `cyclictest -q <args>` with `threads` measuring threads; `args` must include `-h`.
    pub fn spawn(args: Vec<String>, threads: usize, out_path: &Path) -> Result<Self> {
        let args: Vec<String> = std::iter::once("-q".to_string()).chain(args).collect();
        let cmdline = format!("cyclictest {}", args.join(" "));
        // Its histogram is long: write it to a file (a pipe we do not drain would block it).
        let out_file = std::fs::File::create(out_path)
            .with_context(|| format!("create {}", out_path.display()))?;
        let child = Command::new("cyclictest")
            .args(&args)
            .stdout(out_file)
            .stderr(Stdio::piped())
            .spawn()
            .with_context(|| format!("start {cmdline}"))?;
        Ok(Self {
            child: Some(child),
            threads,
            out_path: out_path.to_path_buf(),
            cmdline,
        })
    }

    fn child(&mut self) -> &mut Child {
        self.child
            .as_mut()
            .expect("cyclictest is reaped only by finish")
    }

    /// Wait for it to end (it was given `-D`), staying responsive to Ctrl-C; per-thread samples
    /// (ns, 1 µs resolution, histogram overflows recorded at that thread's max).
    pub fn wait(mut self) -> Result<Vec<Vec<u64>>> {
        while self.child().try_wait()?.is_none() {
            if crate::interrupted() {
                bail!("interrupted"); // killed on drop
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        self.finish()
    }

    /// Stop it with `SIGINT` (it then prints its histogram) and return what [`Cyclictest::wait`]
    /// does.
    pub fn stop(mut self) -> Result<Vec<Vec<u64>>> {
        let id = self.child().id();
        if self.child().try_wait()?.is_none() {
            crate::payload::send_sigint(id).with_context(|| format!("stop {}", self.cmdline))?;
        }
        self.finish()
    }

    fn finish(mut self) -> Result<Vec<Vec<u64>>> {
        let child = self
            .child
            .take()
            .expect("cyclictest is reaped only by finish");
        let out = child.wait_with_output()?;
        // cyclictest exits with status 0 after SIGINT (it handles the signal).
        if !out.status.success() {
            bail!(
                "{} failed ({}): {}",
                self.cmdline,
                out.status,
                String::from_utf8_lossy(&out.stderr).trim()
            );
        }
        let text = std::fs::read_to_string(&self.out_path)
            .with_context(|| format!("read {}", self.out_path.display()))?;
        parse_cyclictest(&text, self.threads)
            .with_context(|| format!("cannot parse the output of {}", self.cmdline))
    }
}

impl Drop for Cyclictest {
    fn drop(&mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// Parse cyclictest's `-h` output into per-thread samples (ns).
pub fn parse_cyclictest(text: &str, threads: usize) -> Result<Vec<Vec<u64>>> {
    let mut samples = vec![Vec::new(); threads];
    let mut overflows = vec![0u64; threads];
    let mut max = vec![0u64; threads];
    let nums = |s: &str| -> Result<Vec<u64>> {
        s.split_whitespace()
            .map(|t| t.parse::<u64>().with_context(|| format!("number {t:?}")))
            .collect()
    };
    for line in text.lines() {
        if let Some(rest) = line.strip_prefix("# Histogram Overflows:") {
            overflows = nums(rest)?;
        } else if let Some(rest) = line.strip_prefix("# Max Latencies:") {
            max = nums(rest)?;
        } else if line.starts_with(|c: char| c.is_ascii_digit()) {
            let v = nums(line)?;
            if v.len() != threads + 1 {
                bail!(
                    "histogram line {line:?} has {} columns, want {}",
                    v.len(),
                    threads + 1
                );
            }
            for k in 0..threads {
                samples[k].extend(std::iter::repeat_n(v[0] * 1000, v[k + 1] as usize));
            }
        }
    }
    if overflows.len() != threads || max.len() != threads {
        bail!("missing '# Histogram Overflows' or '# Max Latencies' lines");
    }
    for k in 0..threads {
        samples[k].extend(std::iter::repeat_n(max[k] * 1000, overflows[k] as usize));
    }
    if samples.iter().all(|s| s.is_empty()) {
        bail!("no histogram lines");
    }
    Ok(samples)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cyclictest_histogram_with_overflows_is_parsed() {
        let text = "000000 000000\t000001\n000003 000002\t000000\n000004 000001\t000002\n\
                    # Total: 000000004 000000004\n# Min Latencies: 00003 00000\n\
                    # Max Latencies: 00972 00004\n# Histogram Overflows: 00001 00001\n";
        let s = parse_cyclictest(text, 2).unwrap();
        assert_eq!(s[0], vec![3000, 3000, 4000, 972_000]);
        assert_eq!(s[1], vec![0, 4000, 4000, 4000]);
        assert!(parse_cyclictest("000001 3\n", 2).is_err());
    }
}
