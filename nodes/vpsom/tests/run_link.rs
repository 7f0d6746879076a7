//! Two hosts on one machine (issue #17): two `vpsom run`s, each in its own iceoryx2 domain
//! (`[ports] domain`: separate shared-memory file prefixes, so they share no shared memory),
//! each hosting some of the nodes, joined only by the link tunnel over localhost TCP.
//!
//! - `recorder_across_the_link_records_what_the_robot_published`: sim + mapper + planner (and a
//!   reference recorder) in domain A, a recorder in domain B; the session terminates, and B's
//!   trace holds every sample of A's topics that A's own recorder saw; depth frames, limited to
//!   `[link.max_hz] depth` (the default 10 Hz), as many as crossed; and the two summaries'
//!   per-topic accounts add up, with nothing lost on a topic under 100 Hz (issue #35,
//!   [`the_accounts_add_up`]).
//!
//! The tests run one at a time (two `vpsom run`s each already fill the 2 CPUs), with buffers
//! deep enough that no recorder loses a sample to the bursts in which samples come over TCP.
//! - `planner_across_the_link_drives_the_robot`: the planner in domain B; its goals cross back,
//!   the robot maps, and the session terminates.
//! - `mapper_across_the_link_gets_each_frame_with_its_detections`: the mapper in domain B, depth
//!   and detections limited to one rate (`[link.max_hz]`): they cross as pairs, and the mapper
//!   finds the detections of every frame it gets.
//! - `a_cut_link_is_counted_and_traffic_resumes`: the TCP connection between the hosts goes
//!   through a proxy this test cuts for a few seconds: both runs go on and terminate, B logs the
//!   loss and the return, counts the gap and the samples lost, and depth frames cross at most
//!   `[link.max_hz] depth` times a second.
#![cfg(feature = "link")]

use runtime::recorder::inspect::{self, TraceInfo};
use std::io::{Read, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};
use vpsom::recording::topic;

/// Hang guard for one run (a session takes ~1 min here; a loaded CI machine is slower).
const RUN_LIMIT: Duration = Duration::from_secs(900);

/// The recorder's channels that come from the robot's topics, one message per sample (depth
/// apart: rate-limited).
const FROM_TOPICS: [&str; 6] = [
    topic::TF,
    topic::TRUTH_TF,
    topic::MAP,
    topic::NAV_GOAL,
    topic::NECK_GOAL,
    topic::DEADLINE,
];

/// One test at a time.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// `[ports]` for both hosts: every small topic 16 deep (the recorders poll every 2 ms; samples
/// from the other host come in bursts); the large ones as deep as the defaults.
const BUFFERS: &str = r#"
[ports]
subscriber_buffer = 16
[ports.topics.map]
subscriber_buffer = 4
[ports.topics."map/grid"]
subscriber_buffer = 4
history_size = 1
[ports.topics."nav/grid"]
subscriber_buffer = 4
history_size = 1
"#;

/// `[link]` for both hosts: the tunnel's own buffers as deep as allowed (2.5 s of robot/state),
/// so a tunnel thread the loaded machine leaves unscheduled for a while still loses nothing.
const LINK_BUFFER: &str = "buffer = 256\n";

fn scratch(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("vpsom-link-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A localhost port nobody listens on (bound, read, released).
fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// A config file for one host: ideal sensing (this tests the link, not the sensing), the
/// host's iceoryx2 domain, and `extra`.
fn host_config(dir: &Path, host: &str, domain: &str, extra: &str) -> PathBuf {
    let ideal = include_str!("../../../config/sensing-ideal.toml");
    let path = dir.join(format!("{host}.toml"));
    // `domain` goes into BUFFERS' [ports] table (a TOML table is opened once).
    let ports = BUFFERS.replacen("[ports]\n", &format!("[ports]\ndomain = \"{domain}\"\n"), 1);
    std::fs::write(&path, format!("{ideal}\n{ports}\n{extra}\n")).unwrap();
    path
}

/// One `vpsom run` in the background, its stderr collected.
struct Run {
    name: &'static str,
    child: Child,
    stderr: Option<JoinHandle<String>>,
    stdout: Option<JoinHandle<String>>,
}

impl Run {
    fn start(name: &'static str, config: &Path, args: &[&str]) -> Self {
        let mut child = Command::new(env!("CARGO_BIN_EXE_vpsom"))
            .arg("--config")
            .arg(config)
            .arg("run")
            .args(args)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let collect = |mut r: Box<dyn Read + Send>| {
            std::thread::spawn(move || {
                let mut s = String::new();
                let _ = r.read_to_string(&mut s);
                s
            })
        };
        let stderr = Some(collect(Box::new(child.stderr.take().unwrap())));
        let stdout = Some(collect(Box::new(child.stdout.take().unwrap())));
        Self {
            name,
            child,
            stderr,
            stdout,
        }
    }

    /// Wait for the run to end (killing it past [`RUN_LIMIT`]); `(success, stdout, stderr)`.
    fn wait(mut self) -> (bool, String, String) {
        let start = Instant::now();
        let status = loop {
            if let Some(s) = self.child.try_wait().unwrap() {
                break Some(s);
            }
            if start.elapsed() > RUN_LIMIT {
                let _ = self.child.kill();
                let _ = self.child.wait();
                break None;
            }
            std::thread::sleep(Duration::from_millis(50));
        };
        let out = self.stdout.take().unwrap().join().unwrap();
        let err = self.stderr.take().unwrap().join().unwrap();
        assert!(
            status.is_some(),
            "{}: hang guard: still running after {RUN_LIMIT:?}\n{out}\n{err}",
            self.name
        );
        (status.is_some_and(|s| s.success()), out, err)
    }
}

impl Drop for Run {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

fn wait_for_file(path: &Path) {
    let start = Instant::now();
    while !path.exists() {
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "{} never appeared",
            path.display()
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Messages a recorder received on `t`: written plus dropped by the recorder itself.
fn received(info: &TraceInfo, t: &str) -> u64 {
    let dropped = info
        .drops
        .as_ref()
        .and_then(|d| d.dropped.get(t).copied())
        .unwrap_or(0);
    info.count(t) + dropped
}

fn metrics(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("metrics.json"))
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    serde_json::from_str(&text).unwrap()
}

/// `ns` has no service in the default iceoryx2 domain: the runs' shared memory stayed in their
/// own domains.
fn nothing_in_the_default_domain(ns: &str) {
    assert!(
        runtime::ports::list_services(ns).unwrap().is_empty(),
        "services of {ns} in the default domain"
    );
}

#[test]
fn recorder_across_the_link_records_what_the_robot_published() {
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch("rec");
    let pid = std::process::id();
    let ns = format!("lk{pid}r");
    let port = free_port();
    let a = host_config(
        &dir,
        "a",
        &format!("l{pid}ra"),
        &format!("[link]\n{LINK_BUFFER}wait_for_peer_s = 120.0\n"),
    );
    let b = host_config(
        &dir,
        "b",
        &format!("l{pid}rb"),
        &format!("[link]\n{LINK_BUFFER}"),
    );
    let (out_a, out_b) = (dir.join("robot"), dir.join("station"));
    let listen = format!("listen:tcp/127.0.0.1:{port}");
    let connect = format!("tcp/127.0.0.1:{port}");
    let station = Run::start(
        "station",
        &b,
        &[
            "--nodes",
            "recorder",
            "--ns",
            &ns,
            "--out",
            out_b.to_str().unwrap(),
            "--link",
            &connect,
        ],
    );
    // The station's recorder subscribes before the robot publishes anything: the robot waits
    // for the link, the link for the station's bridges.
    wait_for_file(&out_b.join("trace.mcap"));
    let start = Instant::now();
    let robot = Run::start(
        "robot",
        &a,
        &[
            "--nodes",
            "sim,mapper,planner,recorder",
            "--ns",
            &ns,
            "--out",
            out_a.to_str().unwrap(),
            "--link",
            &listen,
        ],
    );
    let (ok_a, so_a, se_a) = robot.wait();
    let wall = start.elapsed().as_secs_f64();
    let (ok_b, so_b, se_b) = station.wait();
    assert!(ok_a, "robot failed:\n{so_a}\n{se_a}");
    assert!(ok_b, "station failed:\n{so_b}\n{se_b}");
    assert!(
        se_a.contains("link: every topic is bridged on both hosts"),
        "{se_a}"
    );
    // The robot's planner ended the session, and the station heard it end.
    let m = metrics(&out_a);
    assert!(
        m["termination_reason"]
            .as_str()
            .unwrap()
            .starts_with("planner"),
        "{m}"
    );
    assert!(so_b.contains("| end | planner"), "station:\n{so_b}\n{se_b}");
    let ia = inspect::info(&out_a.join("trace.mcap")).unwrap();
    let ib = inspect::info(&out_b.join("trace.mcap")).unwrap();
    assert!(ib.end.complete, "{ib}");
    for t in FROM_TOPICS {
        let (na, nb) = (received(&ia, t), received(&ib, t));
        assert!(na > 0, "{t}: nothing recorded on the robot\n{ia}");
        // Every sample the robot's own recorder saw crossed (the station may have one or two
        // more: the robot's recorder stops with the sim, the tunnel after it).
        assert!(
            nb >= na,
            "{t}: station {nb} < robot {na}\n{ia}\n{ib}\n{se_b}\nstation's summary:\n{so_b}"
        );
        // ... and none twice (a loop through the tunnel would double them).
        assert!(
            nb <= na + na / 20 + 5,
            "{t}: station {nb} >> robot {na}\n{ia}\n{ib}"
        );
    }
    // The accounts (`--nocapture`): what each host's summary says per topic.
    for (host, out) in [("robot", &so_a), ("station", &so_b)] {
        for l in out.lines().filter(|l| l.starts_with("| link: ")) {
            eprintln!("recorder across the link, {host}: {l}");
        }
    }
    the_accounts_add_up(&so_a, &so_b, &ib);
    // Depth: every frame that crossed is in the trace, and no more than 10 Hz crossed.
    let crossed = account(&so_b, "depth", "in")
        .and_then(|a| a.counts[0])
        .unwrap_or(0) as f64;
    let depth = received(&ib, topic::DEPTH) as f64;
    assert!(
        depth >= 1.0 && depth == crossed,
        "{depth} recorded, {crossed} crossed\n{so_b}"
    );
    assert!(
        depth <= 10.0 * wall + 1.0,
        "{depth} frames in {wall:.0} s\n{so_b}"
    );
    assert!((received(&ia, topic::DEPTH) as f64) > depth, "{ia}\n{ib}");
    nothing_in_the_default_domain(&ns);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn planner_across_the_link_drives_the_robot() {
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch("plan");
    let pid = std::process::id();
    let ns = format!("lk{pid}p");
    let port = free_port();
    let a = host_config(
        &dir,
        "a",
        &format!("l{pid}pa"),
        &format!("[link]\n{LINK_BUFFER}wait_for_peer_s = 120.0\n"),
    );
    let b = host_config(
        &dir,
        "b",
        &format!("l{pid}pb"),
        &format!("[link]\n{LINK_BUFFER}"),
    );
    let (out_a, out_b) = (dir.join("robot"), dir.join("station"));
    let station = Run::start(
        "station",
        &b,
        &[
            "--nodes",
            "planner",
            "--ns",
            &ns,
            "--out",
            out_b.to_str().unwrap(),
            "--link",
            &format!("listen:tcp/127.0.0.1:{port}"),
        ],
    );
    let robot = Run::start(
        "robot",
        &a,
        &[
            "--nodes",
            "sim,mapper,recorder",
            "--ns",
            &ns,
            "--out",
            out_a.to_str().unwrap(),
            "--link",
            &format!("tcp/127.0.0.1:{port}"),
        ],
    );
    let (ok_a, so_a, se_a) = robot.wait();
    let (ok_b, so_b, se_b) = station.wait();
    assert!(ok_a, "robot failed:\n{so_a}\n{se_a}");
    assert!(ok_b, "station failed:\n{so_b}\n{se_b}");
    // The planner on the station ended the session, the robot heard it, and scored a map made
    // by driving where the station's goals sent it.
    let m = metrics(&out_a);
    assert!(
        m["termination_reason"]
            .as_str()
            .unwrap()
            .starts_with("planner"),
        "{m}\n{se_a}"
    );
    assert!(m["path_length_m"].as_f64().unwrap() > 0.5, "{m}");
    assert!(m["objects_estimated"].as_u64().unwrap() > 0, "{m}");
    let ia = inspect::info(&out_a.join("trace.mcap")).unwrap();
    assert!(
        ia.count(topic::NAV_GOAL) > 0 && ia.count(topic::NECK_GOAL) > 0,
        "{ia}"
    );
    assert!(so_a.contains("| link: nav/goal in, "), "{so_a}");
    nothing_in_the_default_domain(&ns);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A localhost TCP forwarder the test can cut and restore: "the network between the hosts".
struct Proxy {
    up: Arc<AtomicBool>,
    conns: Arc<Mutex<Vec<TcpStream>>>,
    _thread: JoinHandle<()>,
}

impl Proxy {
    fn start(listen: u16, target: u16) -> Self {
        let up = Arc::new(AtomicBool::new(true));
        let conns: Arc<Mutex<Vec<TcpStream>>> = Arc::default();
        let (u, c) = (up.clone(), conns.clone());
        let listener = TcpListener::bind(("127.0.0.1", listen)).unwrap();
        listener.set_nonblocking(true).unwrap();
        let thread = std::thread::spawn(move || {
            // Bounded: the test's runs end long before this.
            let until = Instant::now() + RUN_LIMIT;
            while Instant::now() < until {
                match listener.accept() {
                    Ok((inbound, _)) if u.load(Ordering::Relaxed) => {
                        let Ok(outbound) = TcpStream::connect(("127.0.0.1", target)) else {
                            continue;
                        };
                        inbound.set_nonblocking(false).unwrap();
                        let mut list = c.lock().unwrap();
                        list.push(inbound.try_clone().unwrap());
                        list.push(outbound.try_clone().unwrap());
                        pump(inbound.try_clone().unwrap(), outbound.try_clone().unwrap());
                        pump(outbound, inbound);
                    }
                    Ok((refused, _)) => drop(refused),
                    Err(_) => std::thread::sleep(Duration::from_millis(10)),
                }
            }
        });
        Self {
            up,
            conns,
            _thread: thread,
        }
    }

    /// Cut every connection and refuse new ones.
    fn cut(&self) {
        self.up.store(false, Ordering::Relaxed);
        for s in self.conns.lock().unwrap().drain(..) {
            let _ = s.shutdown(Shutdown::Both);
        }
    }

    /// Accept connections again.
    fn restore(&self) {
        self.up.store(true, Ordering::Relaxed);
    }
}

#[test]
fn mapper_across_the_link_gets_each_frame_with_its_detections() {
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch("map");
    let pid = std::process::id();
    let ns = format!("lk{pid}m");
    let port = free_port();
    // Depth and detections limited together: they cross as pairs (a frame and its detections);
    // the station mapper's maps come back limited too, through the ObjectMap relay.
    const PAIR_HZ: f64 = 5.0;
    const MAP_HZ: f64 = 4.0;
    let limit =
        format!("[link.max_hz]\ndepth = {PAIR_HZ}\ndetections = {PAIR_HZ}\nmap = {MAP_HZ}\n");
    let a = host_config(
        &dir,
        "a",
        &format!("l{pid}ma"),
        &format!("[link]\n{LINK_BUFFER}wait_for_peer_s = 120.0\n{limit}"),
    );
    let b = host_config(
        &dir,
        "b",
        &format!("l{pid}mb"),
        &format!("[link]\n{LINK_BUFFER}{limit}"),
    );
    let (out_a, out_b) = (dir.join("robot"), dir.join("station"));
    let station = Run::start(
        "station",
        &b,
        &[
            "--nodes",
            "mapper",
            "--ns",
            &ns,
            "--out",
            out_b.to_str().unwrap(),
            "--link",
            &format!("listen:tcp/127.0.0.1:{port}"),
        ],
    );
    let robot = Run::start(
        "robot",
        &a,
        &[
            "--nodes",
            "sim,planner,recorder",
            "--ns",
            &ns,
            "--out",
            out_a.to_str().unwrap(),
            "--link",
            &format!("tcp/127.0.0.1:{port}"),
        ],
    );
    let (ok_a, so_a, se_a) = robot.wait();
    let (ok_b, so_b, se_b) = station.wait();
    assert!(ok_a, "robot failed:\n{so_a}\n{se_a}");
    assert!(ok_b, "station failed:\n{so_b}\n{se_b}");
    // The robot scored a map the station's mapper made from the pairs that crossed, and every
    // map the station's relay sent arrived whole (decoded and validated on the robot).
    let m = metrics(&out_a);
    assert!(m["objects_estimated"].as_u64().unwrap() > 0, "{m}\n{se_a}");
    let sent = account(&so_b, "map", "out").expect("station's map account");
    let came = account(&so_a, "map", "in").expect("robot's map account");
    println!("maps: station {sent:?}, robot {came:?}");
    assert!(sent.hz <= MAP_HZ, "{so_b}");
    let maps = sent.counts[1].expect("crossed is counted");
    assert!(maps > 0, "{so_b}");
    assert_eq!(came.counts[0], Some(maps), "{so_a}\n{so_b}");
    // The robot's recorder read them (but those that came after it stopped).
    let ia = inspect::info(&out_a.join("trace.mcap")).unwrap();
    let recorded = received(&ia, topic::MAP);
    assert!(
        recorded <= maps && maps - recorded <= 2,
        "{recorded} of {maps}\n{ia}"
    );
    // As many detections crossed as frames, and the mapper found the detections of every
    // frame it got (independent newest-first relays would leave most frames unmatched).
    let depth = account(&so_a, "depth", "out").expect("robot's depth account");
    let dets = account(&so_a, "detections", "out").expect("robot's detections account");
    println!("robot: depth {depth:?}, detections {dets:?}");
    let crossed = |a: &Account| a.counts[1].expect("crossed is counted");
    assert!(crossed(&depth) > 0, "{so_a}");
    assert_eq!(crossed(&depth), crossed(&dets), "{so_a}");
    // What the relays moved (`--nocapture`): bytes and copy time per limited topic.
    for (host, out) in [("robot", &so_a), ("station", &so_b)] {
        for l in out
            .lines()
            .filter(|l| l.starts_with("| link: bytes crossed") || l.starts_with("| link: relay "))
        {
            eprintln!("mapper across the link, {host}: {l}");
        }
    }
    let integrated = row(&so_b, "depth frames integrated by the mapper").unwrap();
    let unmatched = row(
        &so_b,
        "frames skipped by the mapper (no matching detections)",
    )
    .unwrap();
    println!("station mapper: {integrated} frames integrated, {unmatched} without detections");
    assert!(integrated > 0.0, "{so_b}");
    // The pairs that were still crossing when the mapper stopped may miss their detections.
    assert!(
        unmatched <= 2.0,
        "{unmatched} of {integrated} frames unmatched\n{so_b}"
    );
    nothing_in_the_default_domain(&ns);
    let _ = std::fs::remove_dir_all(&dir);
}

fn pump(mut from: TcpStream, mut to: TcpStream) {
    std::thread::spawn(move || {
        let mut buf = vec![0u8; 1 << 16];
        while let Ok(n) = from.read(&mut buf) {
            if n == 0 || to.write_all(&buf[..n]).is_err() {
                break;
            }
        }
        let _ = to.shutdown(Shutdown::Both);
    });
}

/// One topic's account row of a run summary (`deploy::link::LinkReport::rows`).
#[derive(Debug)]
struct Account {
    /// The topic's wall rate, Hz.
    hz: f64,
    /// `in`: received / lost in the tunnel / dropped by local subscribers; `out`: published /
    /// crossed / dropped by local subscribers (`None`: `-`, not counted).
    counts: [Option<u64>; 3],
    /// The per-node part of the drop count, e.g. `(recorder 0, planner 0)`.
    by_node: String,
}

/// The account row of `topic` (`dir`: `in` or `out`) in a summary.
fn account(out: &str, topic: &str, dir: &str) -> Option<Account> {
    let prefix = format!("| link: {topic} {dir}, ");
    let line = out.lines().find(|l| l.starts_with(&prefix))?;
    let hz = line[prefix.len()..].split(' ').next()?.parse().ok()?;
    let cell = line.split('|').nth(2)?.trim();
    let mut parts = cell.split(" / ");
    let mut counts = [None; 3];
    for c in &mut counts {
        *c = parts.next()?.split_whitespace().next()?.parse().ok();
    }
    let by_node = cell
        .find('(')
        .map_or(String::new(), |i| cell[i..].to_string());
    Some(Account {
        hz,
        counts,
        by_node,
    })
}

/// Samples the station's recorder lost to overflow on `topic` (`(recorder N)` in its row).
fn recorder_dropped(a: &Account) -> u64 {
    a.by_node
        .trim_matches(|c| c == '(' || c == ')')
        .split(", ")
        .find_map(|p| p.strip_prefix("recorder "))
        .and_then(|n| n.parse().ok())
        .unwrap_or(0)
}

/// The recorder channels that hold one message per sample of a topic from the robot.
const CHANNEL_OF: [(&str, &str); 6] = [
    ("robot/state", topic::TF),
    ("sim/truth", topic::TRUTH_TF),
    ("map", topic::MAP),
    ("nav/goal", topic::NAV_GOAL),
    ("neck/goal", topic::NECK_GOAL),
    ("deadline", topic::DEADLINE),
];

/// Issue #35's accounting, per topic the robot published and the station received: the
/// robot's `published / crossed`, the station's `received / lost in the tunnel / dropped`.
/// - every sequence number the robot used arrived at the station or is counted lost there
///   (what the robot's tunnel did not take among them);
/// - the station's recorder read what arrived less what it counted as its own overflow, and
///   every one of those is in its trace (written, or dropped and counted by the recorder);
/// - no topic under 100 Hz lost anything, and a rate-limited topic (depth) lost nothing
///   between the robot's relay and the station's.
fn the_accounts_add_up(robot: &str, station: &str, trace: &TraceInfo) {
    let mut checked = 0;
    for line in station
        .lines()
        .filter(|l| l.starts_with("| link: ") && !l.starts_with("| link: WARNING"))
    {
        let Some((topic, _)) = line["| link: ".len()..].split_once(" in, ") else {
            continue;
        };
        let st = account(station, topic, "in").unwrap_or_else(|| panic!("{line}"));
        let rb = account(robot, topic, "out")
            .unwrap_or_else(|| panic!("{topic}: no account on the robot\n{robot}"));
        let [published, crossed, _] = rb.counts.map(Option::unwrap_or_default);
        let arrived = st.counts[0].unwrap();
        let ctx = format!("{topic}: robot {rb:?}, station {st:?}\n{station}");
        match st.counts[1] {
            // Rate-limited: the relay's copies are what crossed.
            None => assert_eq!(arrived, crossed, "{ctx}"),
            Some(lost) => {
                assert_eq!(arrived + lost, published, "unexplained loss: {ctx}");
                let dropped = st.counts[2].unwrap();
                if st.hz < 100.0 {
                    assert_eq!(lost, 0, "lost in the tunnel: {ctx}");
                    assert_eq!(dropped, 0, "dropped by a subscriber: {ctx}");
                }
                if let Some(&(_, channel)) = CHANNEL_OF.iter().find(|c| c.0 == topic) {
                    let read = arrived.saturating_sub(recorder_dropped(&st));
                    assert_eq!(
                        received(trace, channel),
                        read,
                        "{channel}: the station's trace against what its recorder read: {ctx}\n{trace}"
                    );
                }
            }
        }
        checked += 1;
    }
    assert!(checked >= CHANNEL_OF.len(), "{checked} accounts\n{station}");
}

/// A number after `label` in a summary table row `| label | N |`.
fn row(out: &str, label: &str) -> Option<f64> {
    let line = out
        .lines()
        .find(|l| l.starts_with(&format!("| {label} |")))?;
    let cell = line.split('|').nth(2)?.trim();
    cell.split_whitespace().next()?.parse().ok()
}

#[test]
fn a_cut_link_is_counted_and_traffic_resumes() {
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch("cut");
    let pid = std::process::id();
    let ns = format!("lk{pid}c");
    let (port, proxy_port) = (free_port(), free_port());
    const DEPTH_HZ: f64 = 4.0;
    let limit = format!("[link.max_hz]\ndepth = {DEPTH_HZ}\n");
    let a = host_config(
        &dir,
        "a",
        &format!("l{pid}ca"),
        &format!("[link]\n{LINK_BUFFER}wait_for_peer_s = 120.0\n{limit}"),
    );
    let b = host_config(
        &dir,
        "b",
        &format!("l{pid}cb"),
        &format!("[link]\n{LINK_BUFFER}{limit}"),
    );
    let (out_a, out_b) = (dir.join("robot"), dir.join("station"));
    let proxy = Proxy::start(proxy_port, port);
    let station = Run::start(
        "station",
        &b,
        &[
            "--nodes",
            "recorder",
            "--ns",
            &ns,
            "--out",
            out_b.to_str().unwrap(),
            "--link",
            &format!("tcp/127.0.0.1:{proxy_port}"),
        ],
    );
    wait_for_file(&out_b.join("trace.mcap"));
    let start = Instant::now();
    let robot = Run::start(
        "robot",
        &a,
        &[
            "--nodes",
            "sim,mapper,planner",
            "--ns",
            &ns,
            "--out",
            out_a.to_str().unwrap(),
            "--link",
            &format!("listen:tcp/127.0.0.1:{port}"),
        ],
    );
    // Cut the link for 3 s once the session is under way, then restore it.
    std::thread::sleep(Duration::from_secs(8));
    proxy.cut();
    std::thread::sleep(Duration::from_secs(3));
    proxy.restore();
    let (ok_a, so_a, se_a) = robot.wait();
    let wall = start.elapsed().as_secs_f64();
    let (ok_b, so_b, se_b) = station.wait();
    assert!(ok_a, "robot failed:\n{so_a}\n{se_a}");
    assert!(ok_b, "station failed:\n{so_b}\n{se_b}");
    // The robot went on without the station and ended the session itself.
    let m = metrics(&out_a);
    assert!(
        m["termination_reason"]
            .as_str()
            .unwrap()
            .starts_with("planner"),
        "{m}\n{se_a}"
    );
    // The station saw the link go and come back, counted the gap and the lost samples, and
    // heard the end of the session after it.
    assert!(se_b.contains("link: lost the other host"), "{se_b}");
    assert!(
        se_b.contains("link: the other host is back after"),
        "{se_b}"
    );
    assert!(
        row(&so_b, "link: times the other host was lost (total s)").unwrap_or(0.0) >= 1.0,
        "{so_b}"
    );
    let lost = account(&so_b, "robot/state", "in")
        .and_then(|a| a.counts[1])
        .unwrap_or(0) as f64;
    // The figures (`--nocapture`): the gap as logged, what each side counted.
    for l in se_b
        .lines()
        .filter(|l| l.contains("the other host is back after"))
    {
        eprintln!("cut link, station: {l}");
    }
    for l in so_b.lines().filter(|l| l.starts_with("| link: ")) {
        eprintln!("cut link, station: {l}");
    }
    for l in so_a
        .lines()
        .filter(|l| l.starts_with("| ") && (l.contains("link: times") || l.contains("LBV")))
    {
        eprintln!("cut link, robot: {l}");
    }
    assert!(lost > 0.0, "no robot/state samples counted lost:\n{so_b}");
    assert!(so_b.contains("| end | planner"), "station:\n{so_b}\n{se_b}");
    // Depth frames crossed at most DEPTH_HZ a second (wall time: fewer frames on a slow
    // machine, never more), and some did.
    let depth = account(&so_b, "depth", "in")
        .and_then(|a| a.counts[0])
        .unwrap_or(0) as f64;
    assert!(depth >= 1.0, "{so_b}");
    assert!(
        depth <= DEPTH_HZ * wall + 1.0,
        "{depth} depth frames in {wall:.0} s at most {DEPTH_HZ} Hz\n{so_b}"
    );
    nothing_in_the_default_domain(&ns);
    let _ = std::fs::remove_dir_all(&dir);
}
