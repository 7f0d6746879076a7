//! `ipc --layer link`: one-way latency and loss between two processes in two iceoryx2 domains
//! joined only by the link tunnel (`vpsom run --link`'s, over zenoh on localhost TCP), next to
//! plain zenoh pub/sub between two processes with the same payload bytes and reliability. The
//! ratio of the two is what the tunnel costs over the zenoh it runs on.
//!
//! The parent is the receiver, in its own domain; each case re-executes this binary as the
//! hidden `link-peer` subcommand (the publisher, in another domain), which listens on a free
//! localhost port that the parent connects to. Tunnel case: the child publishes through the
//! runtime's ports and runs a tunnel thread; the parent runs a tunnel thread and receives
//! through the ports (woken by the paired event). Zenoh case: the child `put`s the sample's
//! bytes, the parent receives them from a zenoh subscriber. Latency = receive time − the send
//! stamp in the header (`CLOCK_MONOTONIC`, system-wide). Services overwrite (a tunnel never
//! backpressures a publisher), so flat out, samples the tunnel cannot keep up with are lost:
//! counted from the sequence numbers.

use crate::Outcome;
use crate::payload::{Bytes4M, Bytes8K, Bytes64, Bytes600K};
use crate::report::{SampleLog, Series, histogram_png};
use crate::settings::IpcSettings;
use crate::stats::{Stats, ratio, table_header, table_row};
use anyhow::{Context, Result, anyhow, bail};
use iceoryx2::prelude::*;
use runtime::clock::{Clock, MonotonicClock};
use runtime::ports::{Overflow, PortContext, PortsConfig, Stamp};
use serde::Serialize;
use serde_json::json;
use shm_types::{AnyBitPattern, Header, Message};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use vpsom::deploy::link::{open_link, parse_endpoint, zenoh_config};
use zenoh::Wait;

/// Topic of every case.
const TOPIC: &str = "bench";

/// One measured case.
#[derive(Debug, Clone, Serialize)]
pub struct LinkCase {
    /// Payload name.
    pub payload: String,
    /// Hz; 0 = flat out.
    pub rate_hz: f64,
    /// `"tunnel"` (iceoryx2 link over zenoh) or `"zenoh"` (plain zenoh pub/sub).
    pub transport: String,
    /// Latency of the received messages.
    pub latency: Stats,
    /// Messages sent (after the warm-up).
    pub sent: u64,
    /// Messages received.
    pub received: u64,
    /// Messages never received.
    pub lost: u64,
    /// Achieved receive rate, 1/s.
    pub rate_achieved: f64,
    #[serde(skip)]
    latencies: Vec<u64>,
    #[serde(skip)]
    times: Vec<u64>,
}

/// What parent and child agree on (the child's command line).
#[derive(Debug, Clone)]
pub struct PeerWire {
    /// `"tunnel"` or `"zenoh"`.
    pub transport: String,
    /// Namespace of the case.
    pub ns: String,
    /// iceoryx2 domain of the child.
    pub domain: String,
    /// Payload name.
    pub payload: String,
    /// Hz, 0 = flat out.
    pub rate_hz: f64,
    /// Measured messages.
    pub count: u64,
    /// Warm-up messages.
    pub warmup: u64,
    /// Subscriber buffer.
    pub buffer: usize,
    /// Port the child listens on.
    pub port: u16,
}

impl PeerWire {
    fn args(&self) -> Vec<String> {
        [
            "link-peer",
            "--transport",
            &self.transport,
            "--ns",
            &self.ns,
            "--domain",
            &self.domain,
            "--payload",
            &self.payload,
            "--rate-hz",
            &self.rate_hz.to_string(),
            "--count",
            &self.count.to_string(),
            "--warmup",
            &self.warmup.to_string(),
            "--buffer",
            &self.buffer.to_string(),
            "--port",
            &self.port.to_string(),
        ]
        .iter()
        .map(|s| s.to_string())
        .collect()
    }

    fn ports_config(&self) -> PortsConfig {
        PortsConfig {
            namespace: self.ns.clone(),
            subscriber_buffer: self.buffer,
            subscriber_max_borrowed: 2,
            publisher_max_loaned: 2,
            // The application's port and the tunnel's.
            max_publishers: 2,
            max_subscribers: 2,
            max_nodes: 6,
            overflow: Overflow::Overwrite,
            ..PortsConfig::default()
        }
    }

    fn service(&self) -> String {
        format!("{}/{}/{TOPIC}", runtime::ports::SERVICE_ROOT, self.ns)
    }

    fn zenoh_key(&self) -> String {
        format!("vpsom-rt-tests/{}/{TOPIC}", self.ns)
    }

    fn zenoh(&self, listen: bool) -> Result<zenoh::Config> {
        let ep = if listen {
            format!("listen:tcp/127.0.0.1:{}", self.port)
        } else {
            format!("tcp/127.0.0.1:{}", self.port)
        };
        Ok(zenoh_config(None, &[parse_endpoint(&ep)?])?)
    }
}

struct ChildGuard(Child);

impl Drop for ChildGuard {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn free_port() -> Result<u16> {
    Ok(std::net::TcpListener::bind("127.0.0.1:0")?
        .local_addr()?
        .port())
}

/// Run every case: payloads × rates × {tunnel, zenoh}.
pub fn run(s: &IpcSettings, dir: &Path, log: &mut SampleLog) -> Result<Outcome> {
    let pid = std::process::id();
    runtime::ports::set_domain(&format!("rtb{pid}"))?;
    let mut cases = Vec::new();
    let mut k = 0;
    for &rate in &s.rates_hz {
        for payload in &s.payloads {
            for transport in ["tunnel", "zenoh"] {
                k += 1;
                let wire = PeerWire {
                    transport: transport.into(),
                    ns: format!("rtl{pid}-{k}"),
                    domain: format!("rta{pid}"),
                    payload: payload.clone(),
                    rate_hz: rate,
                    count: if rate > 0.0 {
                        ((rate * s.paced_duration_s).round() as u64).max(1)
                    } else {
                        s.link_flat_messages
                    },
                    warmup: s.warmup_messages.max(5),
                    buffer: s.subscriber_buffer,
                    port: free_port()?,
                };
                let r = run_case(&wire)
                    .with_context(|| format!("link case {payload} {transport} {rate} Hz"))?;
                eprintln!(
                    "link {:>6} {:>6} {:>5} Hz: p50 {:.1} µs p99 {:.1} µs lost {}/{}",
                    r.payload,
                    r.transport,
                    r.rate_hz,
                    r.latency.p50 as f64 / 1e3,
                    r.latency.p99 as f64 / 1e3,
                    r.lost,
                    r.sent
                );
                cases.push(r);
            }
        }
    }
    report(s, dir, log, &cases)
}

fn rate_name(rate: f64) -> String {
    if rate > 0.0 {
        format!("{rate} Hz")
    } else {
        "flat out".into()
    }
}

fn report(s: &IpcSettings, dir: &Path, log: &mut SampleLog, cases: &[LinkCase]) -> Result<Outcome> {
    let mut md = format!(
        "# vpsom-rt-tests ipc --layer link\n\nOne-way latency between two processes in two \
         iceoryx2 domains joined by the link tunnel over zenoh (localhost TCP), and between two \
         processes over plain zenoh pub/sub (same bytes, reliable). Receiver woken by the \
         paired event (tunnel) or zenoh's channel; services overwrite; {} warm-up messages per \
         case; paced cases {} s, flat-out cases {} messages.\n\n",
        s.warmup_messages.max(5),
        s.paced_duration_s,
        s.link_flat_messages
    );
    md += &table_header(&["rate", "payload", "transport", "sent", "lost", "msg/s"]);
    let mut errors = Vec::new();
    for r in cases {
        md += &table_row(
            &[
                rate_name(r.rate_hz),
                r.payload.clone(),
                r.transport.clone(),
                r.sent.to_string(),
                r.lost.to_string(),
                format!("{:.0}", r.rate_achieved),
            ],
            &r.latency,
        );
        let topic = format!(
            "/link/{}/{}/{}",
            r.transport,
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
        if r.received == 0 {
            errors.push(format!(
                "link {} {} {}: nothing received",
                r.payload,
                r.transport,
                rate_name(r.rate_hz)
            ));
        }
    }
    md += "\n## The tunnel's cost (tunnel / plain zenoh)\n\n\
           | rate | payload | tunnel p50 µs | zenoh p50 µs | ratio p50 | ratio p99 | tunnel lost | zenoh lost |\n|---|---|---|---|---|---|---|---|\n";
    let mut ratios = Vec::new();
    for t in cases.iter().filter(|c| c.transport == "tunnel") {
        let Some(z) = cases
            .iter()
            .find(|c| c.transport == "zenoh" && c.payload == t.payload && c.rate_hz == t.rate_hz)
        else {
            continue;
        };
        let (q, q99) = (
            ratio(t.latency.p50, z.latency.p50),
            ratio(t.latency.p99, z.latency.p99),
        );
        md += &format!(
            "| {} | {} | {:.1} | {:.1} | {q:.2} | {q99:.2} | {}/{} | {}/{} |\n",
            rate_name(t.rate_hz),
            t.payload,
            t.latency.p50 as f64 / 1e3,
            z.latency.p50 as f64 / 1e3,
            t.lost,
            t.sent,
            z.lost,
            z.sent
        );
        ratios.push(
            json!({"payload": t.payload, "rate_hz": t.rate_hz, "p50_ratio": q, "p99_ratio": q99}),
        );
    }
    for &rate in &s.rates_hz {
        let series: Vec<Series<'_>> = cases
            .iter()
            .filter(|r| r.rate_hz == rate)
            .map(|r| Series {
                label: format!("{} {}", r.payload, r.transport),
                samples: &r.latencies,
            })
            .collect();
        let tag = if rate > 0.0 {
            format!("{rate}hz")
        } else {
            "flat".into()
        };
        let file = format!("link_{tag}.png");
        histogram_png(
            &dir.join(&file),
            &format!("one-way latency across the link, {}", rate_name(rate)),
            &series,
        )?;
        md += &format!("\n![{}]({file})\n", rate_name(rate));
    }
    Ok(Outcome {
        markdown: md,
        json: json!({"settings": s, "cases": cases, "ratios": ratios}),
        checks: Vec::new(),
        errors,
    })
}

fn run_case(wire: &PeerWire) -> Result<LinkCase> {
    match wire.payload.as_str() {
        "64B" => receive::<Bytes64>(wire),
        "8KiB" => receive::<Bytes8K>(wire),
        "600KiB" => receive::<Bytes600K>(wire),
        "4MiB" => receive::<Bytes4M>(wire),
        p => bail!("unknown payload {p:?}"),
    }
}

/// Drive a tunnel bridging `wire`'s service until `stop`; sets `ready` once the other side is
/// connected and the service is bridged. Wakes on the carrier and, with `wake_on_local`, on the
/// service's event (a publisher here).
fn drive(
    wire: &PeerWire,
    listen: bool,
    wake_on_local: bool,
    stop: &AtomicBool,
    ready: &AtomicBool,
) -> Result<()> {
    let (session, mut link) =
        open_link(wire.zenoh(listen)?, &[wire.service()], &wire.ports_config())?;
    let wake = link
        .listener()
        .map_err(|e| anyhow!("the tunnel's listener: {e}"))?;
    let node = NodeBuilder::new()
        .config(&runtime::ports::iceoryx2_config())
        .create::<ipc::Service>()
        .map_err(|e| anyhow!("node: {e:?}"))?;
    let local = if wake_on_local {
        let name = ServiceName::new(&wire.service()).map_err(|e| anyhow!("{e:?}"))?;
        let ev = node
            .service_builder(&name)
            .event()
            .open()
            .map_err(|e| anyhow!("event service: {e:?}"))?;
        Some(
            ev.listener_builder()
                .create()
                .map_err(|e| anyhow!("listener: {e:?}"))?,
        )
    } else {
        None
    };
    let waitset = WaitSetBuilder::new()
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .map_err(|e| anyhow!("wait set: {e:?}"))?;
    let _g1 = waitset
        .attach_notification(&wake)
        .map_err(|e| anyhow!("attach: {e:?}"))?;
    let _g2 = match &local {
        Some(l) => Some(
            waitset
                .attach_notification(l)
                .map_err(|e| anyhow!("attach: {e:?}"))?,
        ),
        None => None,
    };
    let mut last_discover: Option<Instant> = None;
    while !stop.load(Ordering::Relaxed) {
        let _ = waitset.wait_and_process_once_with_timeout(
            |_| CallbackProgression::Continue,
            Duration::from_millis(10),
        );
        let _ = wake.try_wait(|_| {});
        if let Some(l) = &local {
            let _ = l.try_wait(|_| {});
        }
        if last_discover.is_none_or(|t| t.elapsed() >= Duration::from_millis(50)) {
            last_discover = Some(Instant::now());
            let _ = link.discover();
            let peers = session.info().peers_zid().wait().next().is_some();
            ready.store(peers && !link.bridges().empty(), Ordering::Relaxed);
        }
        let _ = link.propagate();
    }
    let _ = session.close().wait();
    Ok(())
}

/// A tunnel thread for the lifetime of the guard.
struct TunnelThread {
    stop: Arc<AtomicBool>,
    ready: Arc<AtomicBool>,
    handle: Option<std::thread::JoinHandle<Result<()>>>,
}

impl TunnelThread {
    fn start(wire: &PeerWire, listen: bool, wake_on_local: bool) -> Result<Self> {
        let (stop, ready) = (
            Arc::new(AtomicBool::new(false)),
            Arc::new(AtomicBool::new(false)),
        );
        let (s, r, w) = (stop.clone(), ready.clone(), wire.clone());
        let handle = std::thread::Builder::new()
            .name("link".into())
            .spawn(move || drive(&w, listen, wake_on_local, &s, &r))?;
        Ok(Self {
            stop,
            ready,
            handle: Some(handle),
        })
    }

    fn wait_ready(&self, limit: Duration) -> Result<()> {
        let until = Instant::now() + limit;
        while !self.ready.load(Ordering::Relaxed) {
            if Instant::now() > until {
                bail!("the tunnel did not connect within {limit:?}");
            }
            if self.handle.as_ref().is_some_and(|h| h.is_finished()) {
                bail!("the tunnel thread ended");
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        Ok(())
    }

    fn finish(mut self) -> Result<()> {
        self.stop.store(true, Ordering::Relaxed);
        match self.handle.take().map(|h| h.join()) {
            Some(Ok(r)) => r,
            Some(Err(_)) => bail!("the tunnel thread panicked"),
            None => Ok(()),
        }
    }
}

impl Drop for TunnelThread {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

/// The header at the start of a zenoh payload.
fn header_of(bytes: &[u8]) -> Option<Header> {
    let word = |i: usize| {
        bytes
            .get(8 * i..8 * i + 8)
            .map(|b| u64::from_le_bytes(b.try_into().unwrap_or_default()))
    };
    Some(Header {
        seq: word(0)?,
        stamp_ns: word(1)?,
        sim_time_ns: word(2)?,
    })
}

fn receive<T: Message>(wire: &PeerWire) -> Result<LinkCase> {
    let clock = MonotonicClock::new();
    let exe = std::env::current_exe().context("find own executable")?;
    let tunnel = wire.transport == "tunnel";
    // The receiving side first (the tunnel exports its service), then the child.
    let (ctx, sub, thread) = if tunnel {
        let ctx = PortContext::with_namespace(&wire.ports_config(), "rtl-receiver", &wire.ns)?;
        let sub = ctx.subscriber::<T>(TOPIC)?;
        let thread = TunnelThread::start(wire, false, false)?;
        (Some(ctx), Some(sub), Some(thread))
    } else {
        (None, None, None)
    };
    let zsession = if tunnel {
        None
    } else {
        Some(
            zenoh::open(wire.zenoh(false)?)
                .wait()
                .map_err(|e| anyhow!("zenoh session: {e}"))?,
        )
    };
    let zsub = match &zsession {
        Some(s) => Some(
            s.declare_subscriber(wire.zenoh_key())
                .wait()
                .map_err(|e| anyhow!("zenoh subscriber: {e}"))?,
        ),
        None => None,
    };
    let mut child = ChildGuard(
        Command::new(exe)
            .args(wire.args())
            .stdin(Stdio::null())
            .spawn()
            .context("spawn the link-peer child")?,
    );
    let total = wire.warmup + wire.count;
    let expected_s = if wire.rate_hz > 0.0 {
        total as f64 / wire.rate_hz
    } else {
        total as f64 * 0.01
    };
    let deadline = Instant::now() + Duration::from_secs_f64(expected_s + 30.0);
    let (mut times, mut latencies) = (Vec::new(), Vec::new());
    let mut last_seq = 0u64;
    let mut child_done_at: Option<Instant> = None;
    let wait = Duration::from_millis(50);
    while last_seq < total {
        if crate::interrupted() {
            bail!("interrupted");
        }
        let header = match (&sub, &zsub) {
            (Some(s), _) => s.wait(wait)?.map(|r| *r.header()),
            (_, Some(z)) => z
                .recv_timeout(wait)
                .map_err(|e| anyhow!("zenoh receive: {e}"))?
                .and_then(|s| header_of(&s.payload().to_bytes())),
            _ => unreachable!("one receiver per case"),
        };
        match header {
            Some(h) => {
                let now = clock.now_ns();
                if h.seq <= last_seq {
                    continue;
                }
                last_seq = h.seq;
                if h.seq > wire.warmup {
                    times.push(now);
                    latencies.push(now.saturating_sub(h.stamp_ns));
                }
            }
            None => {
                if Instant::now() > deadline {
                    break;
                }
                if let Some(status) = child.0.try_wait()? {
                    if !status.success() {
                        bail!("the link-peer child failed: {status}");
                    }
                    let at = *child_done_at.get_or_insert_with(Instant::now);
                    if at.elapsed() > Duration::from_millis(500) {
                        break;
                    }
                }
            }
        }
    }
    // Leaving lets the child exit (it waits for the receiver to go).
    drop(sub);
    if let Some(t) = thread {
        t.finish()?;
    }
    drop(ctx);
    drop(zsub);
    if let Some(s) = zsession {
        let _ = s.close().wait();
    }
    let status = child.0.wait()?;
    if !status.success() {
        bail!("the link-peer child failed: {status}");
    }
    let received = latencies.len() as u64;
    let span = match (times.first(), times.last()) {
        (Some(a), Some(b)) if b > a => (b - a) as f64 / 1e9,
        _ => 0.0,
    };
    Ok(LinkCase {
        payload: wire.payload.clone(),
        rate_hz: wire.rate_hz,
        transport: wire.transport.clone(),
        latency: Stats::of_samples(&latencies),
        sent: wire.count,
        received,
        lost: wire.count.saturating_sub(received),
        rate_achieved: if span > 0.0 {
            received.saturating_sub(1) as f64 / span
        } else {
            0.0
        },
        latencies,
        times,
    })
}

/// The hidden `link-peer` subcommand: in `wire.domain`, publish `warmup + count` messages
/// through the tunnel or plain zenoh, then wait for the receiver to leave.
pub fn peer(wire: &PeerWire) -> Result<()> {
    runtime::ports::set_domain(&wire.domain)?;
    match wire.payload.as_str() {
        "64B" => publish::<Bytes64>(wire),
        "8KiB" => publish::<Bytes8K>(wire),
        "600KiB" => publish::<Bytes600K>(wire),
        "4MiB" => publish::<Bytes4M>(wire),
        p => bail!("unknown payload {p:?}"),
    }
}

fn publish<T: Message + AnyBitPattern>(wire: &PeerWire) -> Result<()> {
    let clock = MonotonicClock::new();
    let period = if wire.rate_hz > 0.0 {
        (1e9 / wire.rate_hz) as u64
    } else {
        0
    };
    let size = std::mem::size_of::<T>();
    if wire.transport == "tunnel" {
        let ctx = PortContext::with_namespace(&wire.ports_config(), "rtl-publisher", &wire.ns)?;
        let p = ctx.publisher::<T>(TOPIC)?;
        let tunnel = TunnelThread::start(wire, true, true)?;
        tunnel.wait_ready(Duration::from_secs(30))?;
        // Both sides' bridges and zenoh declarations settle; the warm-up absorbs the rest.
        std::thread::sleep(Duration::from_millis(300));
        let send = |clock: &MonotonicClock| -> Result<()> {
            p.loan_reused()?.send(Stamp {
                source_ns: clock.now_ns(),
                sim_ns: 0,
            })?;
            Ok(())
        };
        paced(wire, period, &clock, send)?;
        // Stay until the receiver's tunnel has gone (it drains first), at most 30 s.
        let start = Instant::now();
        while tunnel.ready.load(Ordering::Relaxed) && start.elapsed() < Duration::from_secs(30) {
            std::thread::sleep(Duration::from_millis(5));
        }
        tunnel.finish()?;
    } else {
        let session = zenoh::open(wire.zenoh(true)?)
            .wait()
            .map_err(|e| anyhow!("zenoh session: {e}"))?;
        let publisher = session
            .declare_publisher(wire.zenoh_key())
            .reliability(zenoh::qos::Reliability::Reliable)
            .wait()
            .map_err(|e| anyhow!("zenoh publisher: {e}"))?;
        let peers = |s: &zenoh::Session| s.info().peers_zid().wait().next().is_some();
        let start = Instant::now();
        while !peers(&session) {
            if start.elapsed() > Duration::from_secs(30) {
                bail!("no receiver connected");
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        std::thread::sleep(Duration::from_millis(300));
        let mut seq = 0u64;
        let send = |clock: &MonotonicClock| -> Result<()> {
            seq += 1;
            // A fresh buffer per message, as the tunnel's frame is.
            let mut bytes = vec![0u8; size];
            bytes[0..8].copy_from_slice(&seq.to_le_bytes());
            bytes[8..16].copy_from_slice(&clock.now_ns().to_le_bytes());
            publisher
                .put(bytes)
                .wait()
                .map_err(|e| anyhow!("zenoh put: {e}"))
        };
        paced(wire, period, &clock, send)?;
        let start = Instant::now();
        while peers(&session) && start.elapsed() < Duration::from_secs(30) {
            std::thread::sleep(Duration::from_millis(5));
        }
        let _ = session.close().wait();
    }
    Ok(())
}

/// The warm-up spread over >= 300 ms, then `count` messages every `period` ns (0 = flat out).
fn paced(
    wire: &PeerWire,
    period: u64,
    clock: &MonotonicClock,
    mut send: impl FnMut(&MonotonicClock) -> Result<()>,
) -> Result<()> {
    let gap = Duration::from_millis(300) / wire.warmup.max(1) as u32;
    for _ in 0..wire.warmup {
        send(clock)?;
        std::thread::sleep(gap);
    }
    let t0 = clock.now_ns() + period;
    for k in 0..wire.count {
        if period > 0 {
            clock.sleep_until(t0 + k * period);
        }
        send(clock)?;
    }
    Ok(())
}
