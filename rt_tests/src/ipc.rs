//! `ipc`: one-way latency between two processes, through the runtime's ports and through raw
//! iceoryx2 (no runtime layer), for several payload sizes, receive modes and rates.
//!
//! The parent is the receiver; each case re-executes this binary as the hidden `ipc-pub`
//! subcommand (the publisher). Latency = receive time − the send time the publisher wrote into
//! the header just before `send` (both `CLOCK_MONOTONIC`, which is system-wide), so the cost of
//! loaning and filling a sample is excluded in both layers. Each loan is either zero-filled
//! (`zero`: `Publisher::loan`, `shm_types::init_zeroed`) or taken as it is (`reuse`:
//! `Publisher::loan_reused`, `shm_types::init_reused`), the same way in both layers. Services use backpressure
//! (`block`): nothing may be lost, and sequence gaps (loss) and regressions (reordering) are
//! counted and must be zero. Flat out, the publisher sends back to back, so the latency then
//! includes waiting for room in the subscriber's buffer (the achieved rate is reported).

use crate::Outcome;
use crate::payload::{Bytes4M, Bytes8K, Bytes64, Bytes600K};
use crate::report::{BudgetCheck, SampleLog, Series, histogram_png};
use crate::settings::{Budgets, IpcSettings, Sched};
use crate::stats::{Stats, ratio, table_header, table_row};
use anyhow::{Context, Result, anyhow, bail};
use iceoryx2::port::{BackpressureAction, BackpressureInfo};
use iceoryx2::prelude::{BackpressureStrategy, NodeBuilder, PortFactory as _, ServiceName, ipc};
use runtime::clock::{Clock, MonotonicClock};
use runtime::ports::{Overflow, PortContext, PortsConfig, Stamp};
use serde::Serialize;
use serde_json::json;
use shm_types::{AnyBitPattern, Header, Message};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Topic of every case.
const TOPIC: &str = "bench";

/// One measured case.
#[derive(Debug, Clone, Serialize)]
pub struct CaseResult {
    /// Payload name.
    pub payload: String,
    /// `"poll"` or `"event"`.
    pub mode: String,
    /// Hz; 0 = flat out.
    pub rate_hz: f64,
    /// `"ports"` (runtime) or `"raw"` (iceoryx2).
    pub layer: String,
    /// How the publisher prepares each loan: `"zero"` (zero-filled) or `"reuse"` (as it is).
    pub fill: String,
    /// Latency.
    pub latency: Stats,
    /// Messages measured (after the warm-up).
    pub received: u64,
    /// Messages never received.
    pub lost: u64,
    /// Messages received after a later one.
    pub reordered: u64,
    /// Achieved message rate, 1/s (over the time between first and last receive of each round).
    pub rate_achieved: f64,
    /// Seconds from first to last receive, summed over rounds.
    #[serde(skip)]
    busy_s: f64,
    /// Receive intervals within those spans.
    #[serde(skip)]
    intervals: u64,
    /// Receive times, ns (parallel to `latencies`).
    #[serde(skip)]
    times: Vec<u64>,
    /// Latencies, ns.
    #[serde(skip)]
    latencies: Vec<u64>,
}

/// Parameters shared by parent and child (passed on the child's command line).
#[derive(Debug, Clone)]
pub struct Wire {
    /// Namespace of the case.
    pub ns: String,
    /// Payload name.
    pub payload: String,
    /// Layer.
    pub raw: bool,
    /// Rate, Hz (0 = flat out).
    pub rate_hz: f64,
    /// Measured messages.
    pub count: u64,
    /// Warm-up messages.
    pub warmup: u64,
    /// Subscriber buffer.
    pub buffer: usize,
    /// Notify the paired event on every send (always with the runtime's ports).
    pub notify: bool,
    /// Loan without zero-filling (`loan_reused` / `init_reused`) instead of zero-filled.
    pub reuse: bool,
}

impl Wire {
    fn args(&self) -> Vec<String> {
        let mut a = vec![
            "ipc-pub".to_string(),
            "--ns".into(),
            self.ns.clone(),
            "--payload".into(),
            self.payload.clone(),
            "--rate-hz".into(),
            self.rate_hz.to_string(),
            "--count".into(),
            self.count.to_string(),
            "--warmup".into(),
            self.warmup.to_string(),
            "--buffer".into(),
            self.buffer.to_string(),
        ];
        if self.raw {
            a.push("--raw".into());
        }
        if self.notify {
            a.push("--notify".into());
        }
        if self.reuse {
            a.push("--reuse".into());
        }
        a
    }

    fn ports_config(&self) -> PortsConfig {
        PortsConfig {
            namespace: self.ns.clone(),
            subscriber_buffer: self.buffer,
            subscriber_max_borrowed: 2,
            publisher_max_loaned: 2,
            max_publishers: 1,
            max_subscribers: 1,
            max_nodes: 4,
            overflow: Overflow::Block,
            block_timeout_ms: 10_000,
            ..PortsConfig::default()
        }
    }
}

/// Kills the child on drop.
struct ChildGuard(Child);

impl Drop for ChildGuard {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Run every configured case.
pub fn run(s: &IpcSettings, budgets: &Budgets, dir: &Path, log: &mut SampleLog) -> Result<Outcome> {
    let layers: &[bool] = if s.raw { &[false, true] } else { &[false] };
    let mut cases: Vec<(Wire, bool)> = Vec::new();
    for &rate in &s.rates_hz {
        for mode in &s.modes {
            for fill in &s.fills {
                for payload in &s.payloads {
                    for &raw in layers {
                        let wire = Wire {
                            ns: String::new(),
                            payload: payload.clone(),
                            raw,
                            rate_hz: rate,
                            count: if rate > 0.0 {
                                ((rate * s.paced_duration_s).round() as u64).max(1)
                            } else {
                                s.flat_messages
                            },
                            warmup: s.warmup_messages,
                            buffer: s.subscriber_buffer,
                            notify: !raw || mode == "event",
                            reuse: fill == "reuse",
                        };
                        cases.push((wire, mode == "event"));
                    }
                }
            }
        }
    }
    // Round k runs every case with its k-th share of the messages, so a slow drift of the
    // machine (other tenants, frequency) affects every case alike instead of whichever ran then.
    let rounds = u64::from(s.rounds);
    let mut results: Vec<Option<CaseResult>> = vec![None; cases.len()];
    for round in 0..rounds {
        if rounds > 1 {
            eprintln!("ipc round {}/{rounds}", round + 1);
        }
        for (k, ((wire, event), merged)) in cases.iter().zip(&mut results).enumerate() {
            let share = wire.count / rounds + u64::from(round < wire.count % rounds);
            if share == 0 {
                continue;
            }
            let part = Wire {
                ns: format!("rtt{}-{k}-{round}", std::process::id()),
                count: share,
                ..wire.clone()
            };
            let r = run_case(&part, *event, &s.sched, &s.publisher_cpus).with_context(|| {
                format!(
                    "ipc case {} {} {} Hz {} {}",
                    wire.payload,
                    if *event { "event" } else { "poll" },
                    wire.rate_hz,
                    if wire.raw { "raw" } else { "ports" },
                    fill_name(wire.reuse)
                )
            })?;
            match merged {
                Some(m) => m.absorb(r),
                None => *merged = Some(r),
            }
        }
    }
    let results: Vec<CaseResult> = results.into_iter().flatten().collect();
    for r in &results {
        eprintln!(
            "ipc {:>6} {:>5} {:>5} Hz {:>5} {:>5}: p50 {:.1} µs p99 {:.1} µs lost {} reordered {}",
            r.payload,
            r.mode,
            r.rate_hz,
            r.layer,
            r.fill,
            r.latency.p50 as f64 / 1e3,
            r.latency.p99 as f64 / 1e3,
            r.lost,
            r.reordered
        );
    }
    report(s, budgets, dir, log, &results)
}

impl CaseResult {
    /// Add another round of the same case.
    fn absorb(&mut self, r: CaseResult) {
        self.received += r.received;
        self.lost += r.lost;
        self.reordered += r.reordered;
        self.busy_s += r.busy_s;
        self.intervals += r.intervals;
        self.rate_achieved = if self.busy_s > 0.0 {
            self.intervals as f64 / self.busy_s
        } else {
            0.0
        };
        self.times.extend(r.times);
        self.latencies.extend(r.latencies);
        self.latency = Stats::of_samples(&self.latencies);
    }
}

fn fill_name(reuse: bool) -> &'static str {
    if reuse { "reuse" } else { "zero" }
}

fn rate_name(rate: f64) -> String {
    if rate > 0.0 {
        format!("{rate} Hz")
    } else {
        "flat out".into()
    }
}

fn report(
    s: &IpcSettings,
    budgets: &Budgets,
    dir: &Path,
    log: &mut SampleLog,
    results: &[CaseResult],
) -> Result<Outcome> {
    let mut md = format!(
        "# vpsom-rt-tests ipc\n\nOne-way latency between two processes (receive time − send stamp). \
         Receiver scheduling: {} prio {} cpus {:?}; publisher cpus {:?}; subscriber buffer {} \
         (backpressure); {} warm-up messages per case; paced cases {} s, flat-out cases {} messages. \
         Fill: `zero` = each loan zero-filled by the publisher before the send stamp \
         (`Publisher::loan`), `reuse` = loaned as it is (`Publisher::loan_reused`); raw iceoryx2 the \
         same way.\n\n",
        s.sched.policy,
        s.sched.priority,
        s.sched.cpus,
        s.publisher_cpus,
        s.subscriber_buffer,
        s.warmup_messages,
        s.paced_duration_s,
        s.flat_messages
    );
    md += &table_header(&[
        "rate",
        "mode",
        "payload",
        "fill",
        "layer",
        "lost",
        "reordered",
        "msg/s",
    ]);
    let mut checks = Vec::new();
    let mut errors = Vec::new();
    for r in results {
        md += &table_row(
            &[
                rate_name(r.rate_hz),
                r.mode.clone(),
                r.payload.clone(),
                r.fill.clone(),
                r.layer.clone(),
                r.lost.to_string(),
                r.reordered.to_string(),
                format!("{:.0}", r.rate_achieved),
            ],
            &r.latency,
        );
        let topic = format!(
            "/ipc/{}/{}/{}/{}/{}",
            r.layer,
            r.fill,
            r.mode,
            if r.rate_hz > 0.0 {
                format!("{}hz", r.rate_hz)
            } else {
                "flat".into()
            },
            r.payload
        );
        for (k, (&t, &l)) in r.times.iter().zip(&r.latencies).enumerate() {
            log.record(&topic, t, &json!({"seq": k, "latency_ns": l}))?;
        }
        if r.lost > 0 || r.reordered > 0 {
            errors.push(format!(
                "ipc {} {} {} {} {}: {} lost, {} reordered (must be 0)",
                r.payload,
                r.mode,
                rate_name(r.rate_hz),
                r.fill,
                r.layer,
                r.lost,
                r.reordered
            ));
        }
        if r.layer == "ports" && r.rate_hz > 0.0 {
            checks.push(BudgetCheck::at_most(
                format!(
                    "ipc_p99_us ({} {} {} {})",
                    r.payload,
                    r.mode,
                    rate_name(r.rate_hz),
                    r.fill
                ),
                r.latency.p99 as f64 / 1e3,
                budgets.ipc_p99_us,
                "µs",
            ));
        }
    }
    let find = |like: &CaseResult, payload: &str, layer: &str| {
        results.iter().find(|r| {
            r.payload == payload
                && r.mode == like.mode
                && r.rate_hz == like.rate_hz
                && r.fill == like.fill
                && r.layer == layer
        })
    };
    let mut overhead = Vec::new();
    if s.raw {
        md += "\n## Overhead of the runtime layer (ports p50 / raw iceoryx2 p50)\n\n\
               | rate | mode | payload | fill | ports p50 µs | raw p50 µs | ratio | ratio p99 |\n|---|---|---|---|---|---|---|---|\n";
        for r in results.iter().filter(|r| r.layer == "ports") {
            if let Some(raw) = find(r, &r.payload, "raw") {
                let q = ratio(r.latency.p50, raw.latency.p50);
                let q99 = ratio(r.latency.p99, raw.latency.p99);
                md += &format!(
                    "| {} | {} | {} | {} | {:.1} | {:.1} | {q:.2} | {q99:.2} |\n",
                    rate_name(r.rate_hz),
                    r.mode,
                    r.payload,
                    r.fill,
                    r.latency.p50 as f64 / 1e3,
                    raw.latency.p50 as f64 / 1e3
                );
                overhead.push(json!({"payload": r.payload, "mode": r.mode, "rate_hz": r.rate_hz, "fill": r.fill, "p50_ratio": q, "p99_ratio": q99}));
                checks.push(BudgetCheck::at_most(
                    format!(
                        "ipc_overhead_p50 ({} {} {} {})",
                        r.payload,
                        r.mode,
                        rate_name(r.rate_hz),
                        r.fill
                    ),
                    q,
                    budgets.ipc_overhead_p50,
                    "×",
                ));
            }
        }
    }
    // Zero-copy: p50 of the largest payload vs 8 KiB.
    let mut flatness = Vec::new();
    let largest = ["4MiB", "600KiB"]
        .into_iter()
        .find(|p| s.payloads.iter().any(|q| q == p));
    if let Some(big) = largest.filter(|_| s.payloads.iter().any(|q| q == "8KiB")) {
        md += &format!(
            "\n## Zero-copy flatness (p50 {big} / p50 8KiB − 1)\n\n| rate | mode | fill | layer | 8KiB p50 µs | {big} p50 µs | deviation |\n|---|---|---|---|---|---|---|\n"
        );
        for r in results.iter().filter(|r| r.payload == "8KiB") {
            if let Some(b) = find(r, big, &r.layer) {
                let dev = ratio(b.latency.p50, r.latency.p50) - 1.0;
                md += &format!(
                    "| {} | {} | {} | {} | {:.1} | {:.1} | {:+.1} % |\n",
                    rate_name(r.rate_hz),
                    r.mode,
                    r.fill,
                    r.layer,
                    r.latency.p50 as f64 / 1e3,
                    b.latency.p50 as f64 / 1e3,
                    dev * 100.0
                );
                flatness.push(json!({"mode": r.mode, "rate_hz": r.rate_hz, "fill": r.fill, "layer": r.layer, "large": big, "deviation": dev}));
                if r.layer == "ports" {
                    checks.push(BudgetCheck::at_most(
                        format!(
                            "ipc_flatness ({} {} {})",
                            r.mode,
                            rate_name(r.rate_hz),
                            r.fill
                        ),
                        dev.abs(),
                        budgets.ipc_flatness,
                        "",
                    ));
                }
            }
        }
    }
    for &rate in &s.rates_hz {
        for mode in &s.modes {
            let series: Vec<Series<'_>> = results
                .iter()
                .filter(|r| r.rate_hz == rate && &r.mode == mode)
                .map(|r| Series {
                    label: if s.fills.len() > 1 {
                        format!("{} {} {}", r.payload, r.layer, r.fill)
                    } else {
                        format!("{} {}", r.payload, r.layer)
                    },
                    samples: &r.latencies,
                })
                .collect();
            let tag = if rate > 0.0 {
                format!("{rate}hz")
            } else {
                "flat".into()
            };
            let file = format!("ipc_{mode}_{tag}.png");
            histogram_png(
                &dir.join(&file),
                &format!("one-way latency, {mode}, {}", rate_name(rate)),
                &series,
            )?;
            md += &format!("\n![{mode} {}]({file})\n", rate_name(rate));
        }
    }
    if !errors.is_empty() {
        md += "\n## Errors\n\n";
        for e in &errors {
            md += &format!("- {e}\n");
        }
    }
    Ok(Outcome {
        markdown: md,
        json: json!({"settings": s, "cases": results, "overhead": overhead, "flatness": flatness}),
        checks,
        errors,
    })
}

/// Receiver side of one case, on its own thread with the configured scheduling.
fn run_case(wire: &Wire, event: bool, sched: &Sched, pub_cpus: &[usize]) -> Result<CaseResult> {
    let wire2 = wire.clone();
    let sched = sched.clone();
    let pub_cpus = pub_cpus.to_vec();
    let h = std::thread::Builder::new()
        .name("ipc-receiver".into())
        .spawn(move || -> Result<CaseResult> {
            runtime::executor::apply_sched("ipc-receiver", &sched.executor_config(0));
            match wire2.payload.as_str() {
                "64B" => receive::<Bytes64>(&wire2, event, &sched, &pub_cpus),
                "8KiB" => receive::<Bytes8K>(&wire2, event, &sched, &pub_cpus),
                "600KiB" => receive::<Bytes600K>(&wire2, event, &sched, &pub_cpus),
                "4MiB" => receive::<Bytes4M>(&wire2, event, &sched, &pub_cpus),
                p => bail!("unknown payload {p:?}"),
            }
        })
        .context("spawn receiver thread")?;
    h.join().map_err(|_| anyhow!("receiver thread panicked"))?
}

/// A subscriber of either layer.
enum Sub<T: Message> {
    // The context owns the iceoryx2 node; it must outlive the port.
    Ports(
        Box<runtime::ports::Subscriber<T>>,
        #[allow(dead_code)] Box<PortContext>,
    ),
    Raw(Box<RawSub<T>>),
}

struct RawSub<T: Message> {
    sub: iceoryx2::port::subscriber::Subscriber<ipc::Service, T, ()>,
    listener: iceoryx2::port::listener::Listener<ipc::Service>,
    _node: iceoryx2::node::Node<ipc::Service>,
}

struct RawPub<T: Message> {
    publisher: iceoryx2::port::publisher::Publisher<ipc::Service, T, ()>,
    notifier: iceoryx2::port::notifier::Notifier<ipc::Service>,
    service: iceoryx2::service::port_factory::publish_subscribe::PortFactory<ipc::Service, T, ()>,
    _node: iceoryx2::node::Node<ipc::Service>,
}

type RawServices<T> = (
    iceoryx2::node::Node<ipc::Service>,
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<ipc::Service, T, ()>,
    iceoryx2::service::port_factory::event::PortFactory<ipc::Service>,
);

/// The raw iceoryx2 services, with the same settings as the runtime's ports (`vpsomraw/<ns>/…`).
fn raw_services<T: Message>(wire: &Wire) -> Result<RawServices<T>> {
    let c = wire.ports_config();
    let node = NodeBuilder::new()
        .config(&runtime::ports::iceoryx2_config())
        .create::<ipc::Service>()
        .map_err(|e| anyhow!("raw iceoryx2 node: {e}"))?;
    let name = ServiceName::new(&format!("vpsomraw/{}/{TOPIC}", wire.ns))
        .map_err(|e| anyhow!("raw service name: {e:?}"))?;
    let ps = node
        .service_builder(&name)
        .publish_subscribe::<T>()
        .history_size(0)
        .subscriber_max_buffer_size(c.subscriber_buffer)
        .subscriber_max_borrowed_samples(c.subscriber_max_borrowed)
        .max_publishers(c.max_publishers)
        .max_subscribers(c.max_subscribers)
        .max_nodes(c.max_nodes)
        .enable_safe_overflow(false)
        .open_or_create()
        .map_err(|e| anyhow!("raw publish-subscribe service: {e}"))?;
    let ev = node
        .service_builder(&name)
        .event()
        .max_notifiers(c.max_publishers)
        .max_listeners(c.max_subscribers)
        .max_nodes(c.max_nodes)
        .open_or_create()
        .map_err(|e| anyhow!("raw event service: {e}"))?;
    Ok((node, ps, ev))
}

impl<T: Message> Sub<T> {
    fn open(wire: &Wire) -> Result<Self> {
        if wire.raw {
            let (node, ps, ev) = raw_services::<T>(wire)?;
            let sub = ps
                .subscriber_builder()
                .buffer_size(wire.buffer)
                .create()
                .map_err(|e| anyhow!("raw subscriber: {e}"))?;
            let listener = ev
                .listener_builder()
                .create()
                .map_err(|e| anyhow!("raw listener: {e}"))?;
            Ok(Sub::Raw(Box::new(RawSub {
                sub,
                listener,
                _node: node,
            })))
        } else {
            let ctx = PortContext::with_namespace(&wire.ports_config(), "rtt-receiver", &wire.ns)?;
            let sub = ctx.subscriber::<T>(TOPIC)?;
            Ok(Sub::Ports(Box::new(sub), Box::new(ctx)))
        }
    }

    /// Next message's header (seq, stamp) without blocking (`poll`) or waiting up to 100 ms
    /// for the paired event (`event`).
    fn next(&self, event: bool) -> Result<Option<Header>> {
        let wait = Duration::from_millis(100);
        match self {
            Sub::Ports(s, _) => {
                let r = if event { s.wait(wait)? } else { s.receive()? };
                Ok(r.map(|r| *r.header()))
            }
            Sub::Raw(r) => loop {
                if let Some(s) = r.sub.receive().map_err(|e| anyhow!("raw receive: {e}"))? {
                    return Ok(Some(*s.payload().header()));
                }
                if !event {
                    return Ok(None);
                }
                let got = r
                    .listener
                    .timed_wait(|_| {}, wait)
                    .map_err(|e| anyhow!("raw wait: {e:?}"))?;
                let _ = got;
                if r.sub
                    .has_samples()
                    .map_err(|e| anyhow!("raw receive: {e:?}"))?
                {
                    continue;
                }
                return Ok(None);
            },
        }
    }
}

fn receive<T: Message>(
    wire: &Wire,
    event: bool,
    sched: &Sched,
    pub_cpus: &[usize],
) -> Result<CaseResult> {
    let clock = MonotonicClock::new();
    let sub = Sub::<T>::open(wire)?;
    // Attach the subscriber's end before the publisher exists (backpressure needs it).
    sub.next(false)?;
    let exe = std::env::current_exe().context("find own executable")?;
    let mut cmd = Command::new(exe);
    cmd.args(wire.args())
        .args([
            "--policy",
            &sched.policy,
            "--priority",
            &sched.priority.to_string(),
        ])
        .stdin(Stdio::null());
    if !pub_cpus.is_empty() {
        let list: Vec<String> = pub_cpus.iter().map(|c| c.to_string()).collect();
        cmd.args(["--cpus", &list.join(",")]);
    }
    let mut child = ChildGuard(cmd.spawn().context("spawn the ipc-pub child")?);
    let total = wire.warmup + wire.count;
    let expected_s = if wire.rate_hz > 0.0 {
        total as f64 / wire.rate_hz
    } else {
        total as f64 * 0.001
    };
    let deadline = Instant::now() + Duration::from_secs_f64(expected_s + 15.0);
    let mut times = Vec::with_capacity(wire.count as usize);
    let mut latencies = Vec::with_capacity(wire.count as usize);
    let mut last_seq = 0u64;
    let mut reordered = 0u64;
    let mut child_done_at: Option<Instant> = None;
    while last_seq < total {
        if crate::interrupted() {
            bail!("interrupted");
        }
        match sub.next(event)? {
            Some(h) => {
                let now = clock.now_ns();
                if h.seq <= last_seq {
                    reordered += 1;
                    continue;
                }
                last_seq = h.seq;
                if h.seq > wire.warmup {
                    times.push(now);
                    latencies.push(now.saturating_sub(h.stamp_ns));
                }
            }
            None => {
                if event || latencies.len().is_multiple_of(64) {
                    if Instant::now() > deadline {
                        break;
                    }
                    if let Some(status) = child.0.try_wait()? {
                        if !status.success() {
                            bail!("the ipc-pub child failed: {status}");
                        }
                        let at = *child_done_at.get_or_insert_with(Instant::now);
                        if at.elapsed() > Duration::from_millis(500) {
                            break;
                        }
                    }
                }
                if !event {
                    std::hint::spin_loop();
                }
            }
        }
    }
    drop(sub); // lets the child exit
    let status = child.0.wait()?;
    if !status.success() {
        bail!("the ipc-pub child failed: {status}");
    }
    let received = latencies.len() as u64;
    let span = match (times.first(), times.last()) {
        (Some(a), Some(b)) if b > a => (b - a) as f64 / 1e9,
        _ => 0.0,
    };
    let intervals = if span > 0.0 { received - 1 } else { 0 };
    Ok(CaseResult {
        payload: wire.payload.clone(),
        mode: if event { "event" } else { "poll" }.into(),
        rate_hz: wire.rate_hz,
        layer: if wire.raw { "raw" } else { "ports" }.into(),
        fill: fill_name(wire.reuse).into(),
        latency: Stats::of_samples(&latencies),
        received,
        lost: wire.count.saturating_sub(received),
        reordered,
        rate_achieved: if span > 0.0 {
            intervals as f64 / span
        } else {
            0.0
        },
        busy_s: span,
        intervals,
        times,
        latencies,
    })
}

/// The hidden `ipc-pub` subcommand: publish `warmup + count` messages, then wait for the
/// receiver to leave.
pub fn publisher(wire: &Wire, sched: &Sched) -> Result<()> {
    runtime::executor::apply_sched("ipc-pub", &sched.executor_config(0));
    match wire.payload.as_str() {
        "64B" => publish::<Bytes64>(wire),
        "8KiB" => publish::<Bytes8K>(wire),
        "600KiB" => publish::<Bytes600K>(wire),
        "4MiB" => publish::<Bytes4M>(wire),
        p => bail!("unknown payload {p:?}"),
    }
}

enum Pub<T: Message> {
    // The context owns the iceoryx2 node; it must outlive the port.
    Ports(
        Box<runtime::ports::Publisher<T>>,
        #[allow(dead_code)] Box<PortContext>,
    ),
    Raw(Box<RawPub<T>>),
}

impl<T: Message + AnyBitPattern> Pub<T> {
    fn open(wire: &Wire) -> Result<Self> {
        if wire.raw {
            let (node, ps, ev) = raw_services::<T>(wire)?;
            let timeout = Duration::from_millis(wire.ports_config().block_timeout_ms);
            let publisher = ps
                .publisher_builder()
                .max_loaned_samples(2)
                .backpressure_strategy(BackpressureStrategy::RetryUntilDelivered)
                .set_backpressure_handler(move |info: &BackpressureInfo| {
                    if info.elapsed_time >= timeout {
                        BackpressureAction::DiscardDataAndFail
                    } else {
                        BackpressureAction::Retry
                    }
                })
                .create()
                .map_err(|e| anyhow!("raw publisher: {e}"))?;
            let notifier = ev
                .notifier_builder()
                .create()
                .map_err(|e| anyhow!("raw notifier: {e}"))?;
            Ok(Pub::Raw(Box::new(RawPub {
                publisher,
                notifier,
                service: ps,
                _node: node,
            })))
        } else {
            let ctx = PortContext::with_namespace(&wire.ports_config(), "rtt-publisher", &wire.ns)?;
            let p = ctx.publisher::<T>(TOPIC)?;
            Ok(Pub::Ports(Box::new(p), Box::new(ctx)))
        }
    }

    fn subscribers(&self) -> usize {
        match self {
            Pub::Ports(p, _) => p.subscriber_count(),
            Pub::Raw(r) => r.service.dynamic_config().number_of_subscribers(),
        }
    }

    fn send(&self, seq: u64, wire: &Wire, clock: &MonotonicClock) -> Result<()> {
        match self {
            Pub::Ports(p, _) => {
                let loan = if wire.reuse {
                    p.loan_reused()?
                } else {
                    p.loan()?
                };
                loan.send(Stamp {
                    source_ns: clock.now_ns(),
                    sim_ns: 0,
                })?;
            }
            Pub::Raw(r) => {
                let uninit = r
                    .publisher
                    .loan_uninit()
                    .map_err(|e| anyhow!("raw loan: {e}"))?;
                let mut sample = if wire.reuse {
                    shm_types::init_reused(uninit)
                } else {
                    shm_types::init_zeroed(uninit)
                };
                *sample.payload_mut().header_mut() = Header {
                    seq,
                    stamp_ns: clock.now_ns(),
                    sim_time_ns: 0,
                };
                sample.send().map_err(|e| anyhow!("raw send: {e}"))?;
                if wire.notify {
                    r.notifier
                        .notify()
                        .map_err(|e| anyhow!("raw notify: {e}"))?;
                }
            }
        }
        Ok(())
    }
}

fn publish<T: Message + AnyBitPattern>(wire: &Wire) -> Result<()> {
    let clock = MonotonicClock::new();
    let p = Pub::<T>::open(wire)?;
    let start = Instant::now();
    while p.subscribers() == 0 {
        if start.elapsed() > Duration::from_secs(10) {
            bail!("no subscriber appeared on {}", wire.ns);
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    // The subscriber attaches its end of the connection on its next receive; until then a
    // sample is dropped, not held back. Spread the warm-up over >= 100 ms, longer than the
    // kernel's RT throttling can stall a spinning `SCHED_FIFO` receiver (50 ms of every 1 s),
    // so it has attached before the measured messages.
    let gap = Duration::from_millis(2).max(Duration::from_millis(100) / wire.warmup.max(1) as u32);
    for seq in 1..=wire.warmup {
        p.send(seq, wire, &clock)?;
        std::thread::sleep(gap);
    }
    let period = if wire.rate_hz > 0.0 {
        (1e9 / wire.rate_hz) as u64
    } else {
        0
    };
    let t0 = clock.now_ns() + period;
    for k in 0..wire.count {
        if period > 0 {
            clock.sleep_until(t0 + k * period);
        }
        p.send(wire.warmup + k + 1, wire, &clock)?;
    }
    // Stay until the receiver has left (it drains what is buffered first).
    let start = Instant::now();
    while p.subscribers() > 0 && start.elapsed() < Duration::from_secs(30) {
        std::thread::sleep(Duration::from_millis(2));
    }
    Ok(())
}
