//! `vpsom doctor`: what the runtime can get on this machine. Every privilege is probed on a
//! scratch thread (or reverted at once for process-wide ones), so gathering a report changes
//! nothing.

use std::fmt;
use std::path::PathBuf;

/// Outcome of one privilege probe.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Probe {
    /// Granted.
    Granted,
    /// Refused, with the OS reason.
    Refused(String),
}

impl Probe {
    /// `true` if granted.
    pub fn granted(&self) -> bool {
        matches!(self, Probe::Granted)
    }

    fn from(r: std::io::Result<()>) -> Self {
        match r {
            Ok(()) => Probe::Granted,
            Err(e) => Probe::Refused(e.to_string()),
        }
    }
}

impl fmt::Display for Probe {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Probe::Granted => f.write_str("granted"),
            Probe::Refused(why) => write!(f, "refused ({why})"),
        }
    }
}

/// The machine report.
#[derive(Debug, Clone)]
pub struct Report {
    /// Where iceoryx2's POSIX shared memory (the data segments) lives.
    pub shm_dir: PathBuf,
    /// `(size, available)` bytes of that filesystem, or why it could not be read.
    pub shm_space: Result<(u64, u64), String>,
    /// iceoryx2's root path for its node/service bookkeeping files.
    pub iceoryx2_root: String,
    /// Prefix of every iceoryx2 file.
    pub iceoryx2_prefix: String,
    /// This user may create iceoryx2's bookkeeping files (the root path, or `/tmp` if the root
    /// does not exist yet) and its shared memory in `shm_dir`.
    pub iceoryx2_access: Probe,
    /// `SCHED_FIFO` (priority 1) on a scratch thread.
    pub fifo: Probe,
    /// Highest FIFO priority the kernel allows.
    pub fifo_max_priority: i32,
    /// `mlockall(MCL_CURRENT)` (reverted with `munlockall`).
    pub mlockall: Probe,
    /// Pinning a scratch thread to one CPU.
    pub affinity: Probe,
    /// `SCHED_IDLE` on a scratch thread.
    pub sched_idle: Probe,
    /// Nice −5 on a scratch thread (the executor's fallback when FIFO is refused).
    pub negative_nice: Probe,
    /// Opening `/dev/cpu_dma_latency` for writing (the executor's `cpu_dma_latency_us`).
    pub cpu_latency: Probe,
    /// The kernel's preemption model (`PREEMPT_NONE` kernels delay even FIFO wake-ups behind
    /// long kernel work), from `/sys/kernel/debug/sched/preempt` or `uname -v`.
    pub preemption: String,
    /// `CLOCK_MONOTONIC` resolution, ns.
    pub clock_resolution_ns: Result<u64, String>,
    /// CPUs this process may use.
    pub cpus: usize,
    /// Their indices.
    pub cpu_list: Vec<usize>,
    /// `/proc/sys/kernel/sched_rt_runtime_us` (−1 = RT throttling off).
    pub rt_runtime_us: Option<i64>,
    /// `/proc/sys/kernel/sched_rt_period_us`.
    pub rt_period_us: Option<i64>,
    /// Kernel release (`/proc/sys/kernel/osrelease`).
    pub kernel: String,
    /// Effective user id.
    pub uid: Option<u32>,
}

fn read_trim(path: &str) -> Option<String> {
    std::fs::read_to_string(path)
        .ok()
        .map(|s| s.trim().to_string())
}

/// Run `f` on a fresh thread (so scheduling changes die with it).
fn on_scratch_thread<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    match std::thread::Builder::new()
        .name("vpsom-doctor".into())
        .spawn(f)
    {
        Ok(h) => match h.join() {
            Ok(v) => v,
            Err(p) => std::panic::resume_unwind(p),
        },
        Err(e) => panic!("doctor: cannot spawn a probe thread: {e}"),
    }
}

impl Report {
    /// Probe the machine.
    pub fn gather() -> Self {
        let shm_dir = PathBuf::from("/dev/shm");
        let shm_space = crate::os::fs_space(&shm_dir).map_err(|e| e.to_string());
        let ice = crate::ports::iceoryx2_config();
        let fifo = on_scratch_thread(|| {
            let r = crate::os::set_fifo(1);
            if r.is_ok() {
                let _ = crate::os::set_other();
            }
            Probe::from(r)
        });
        let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
        let field = |name: &str| -> Option<u64> {
            status
                .lines()
                .find(|l| l.starts_with(name))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|v| v.parse().ok())
        };
        // Do not undo a lock this process already holds (e.g. an executor's mlockall).
        let mlockall = if field("VmLck:").unwrap_or(0) > 0 {
            Probe::Granted
        } else {
            let r = crate::os::mlockall_current();
            if r.is_ok() {
                let _ = crate::os::munlockall();
            }
            Probe::from(r)
        };
        let cpu_list = crate::os::affinity().unwrap_or_default();
        let first = cpu_list.first().copied().unwrap_or(0);
        let affinity = on_scratch_thread(move || Probe::from(crate::os::set_affinity(&[first])));
        let sched_idle = on_scratch_thread(|| Probe::from(crate::os::set_idle()));
        let negative_nice = on_scratch_thread(|| Probe::from(crate::os::set_nice(-5)));
        let cpu_latency = Probe::from(
            std::fs::OpenOptions::new()
                .write(true)
                .open("/dev/cpu_dma_latency")
                .map(drop),
        );
        let preemption = read_trim("/sys/kernel/debug/sched/preempt")
            .map(|m| format!("{m} (dynamic; the active mode is in parentheses)"))
            .or_else(|| {
                read_trim("/proc/sys/kernel/version").map(|v| {
                    let model = ["PREEMPT_RT", "PREEMPT_DYNAMIC", "PREEMPT"]
                        .into_iter()
                        .find(|m| v.contains(m))
                        .unwrap_or("none or voluntary");
                    let note = if model == "PREEMPT_DYNAMIC" {
                        "; active mode unknown (/sys/kernel/debug/sched/preempt unreadable)"
                    } else {
                        ""
                    };
                    format!("{model}{note}")
                })
            })
            .unwrap_or_else(|| "unknown".into());
        let uid = status
            .lines()
            .find(|l| l.starts_with("Uid:"))
            .and_then(|l| l.split_whitespace().nth(2))
            .and_then(|v| v.parse().ok());
        let root = std::path::PathBuf::from(ice.global.root_path().to_string());
        let iceoryx2_access = Probe::from(
            [root.join("nodes"), root.join("services")]
                .iter()
                .filter(|d| d.exists())
                .map(|d| crate::os::dir_writable(d))
                .chain(std::iter::once(if root.exists() {
                    crate::os::dir_writable(&root)
                } else {
                    crate::os::dir_writable(root.parent().unwrap_or(&root))
                }))
                .chain(std::iter::once(crate::os::dir_writable(&shm_dir)))
                .collect::<std::io::Result<Vec<()>>>()
                .map(|_| ()),
        );
        Self {
            iceoryx2_access,
            shm_dir,
            shm_space,
            iceoryx2_root: ice.global.root_path().to_string(),
            iceoryx2_prefix: ice.global.prefix.to_string(),
            fifo,
            fifo_max_priority: crate::os::fifo_max_priority(),
            mlockall,
            affinity,
            sched_idle,
            negative_nice,
            cpu_latency,
            preemption,
            clock_resolution_ns: crate::os::monotonic_resolution_ns().map_err(|e| e.to_string()),
            cpus: std::thread::available_parallelism().map_or(cpu_list.len(), |n| n.get()),
            cpu_list,
            rt_runtime_us: read_trim("/proc/sys/kernel/sched_rt_runtime_us")
                .and_then(|s| s.parse().ok()),
            rt_period_us: read_trim("/proc/sys/kernel/sched_rt_period_us")
                .and_then(|s| s.parse().ok()),
            kernel: read_trim("/proc/sys/kernel/osrelease").unwrap_or_else(|| "unknown".into()),
            uid,
        }
    }
}

fn mib(b: u64) -> f64 {
    b as f64 / (1024.0 * 1024.0)
}

impl fmt::Display for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "kernel:             {}", self.kernel)?;
        match self.uid {
            Some(u) => writeln!(f, "user id:            {u}")?,
            None => writeln!(f, "user id:            unknown")?,
        }
        writeln!(f, "cpus:               {} {:?}", self.cpus, self.cpu_list)?;
        match &self.shm_space {
            Ok((size, avail)) => writeln!(
                f,
                "shared memory:      {} ({:.0} MiB free of {:.0} MiB)",
                self.shm_dir.display(),
                mib(*avail),
                mib(*size)
            )?,
            Err(e) => writeln!(
                f,
                "shared memory:      {} (unreadable: {e})",
                self.shm_dir.display()
            )?,
        }
        writeln!(
            f,
            "iceoryx2:           root {} prefix {} (config built in code, no iceoryx2.toml read)",
            self.iceoryx2_root, self.iceoryx2_prefix
        )?;
        writeln!(f, "iceoryx2 access:    {}", self.iceoryx2_access)?;
        writeln!(
            f,
            "SCHED_FIFO:         {} (max priority {})",
            self.fifo, self.fifo_max_priority
        )?;
        writeln!(f, "mlockall:           {}", self.mlockall)?;
        writeln!(f, "CPU affinity:       {}", self.affinity)?;
        writeln!(f, "SCHED_IDLE:         {}", self.sched_idle)?;
        writeln!(f, "negative nice:      {}", self.negative_nice)?;
        writeln!(
            f,
            "CPU latency limit:  {} (/dev/cpu_dma_latency)",
            self.cpu_latency
        )?;
        writeln!(f, "preemption:         {}", self.preemption)?;
        match &self.clock_resolution_ns {
            Ok(ns) => writeln!(f, "clock resolution:   {ns} ns (CLOCK_MONOTONIC)")?,
            Err(e) => writeln!(f, "clock resolution:   unknown ({e})")?,
        }
        match (self.rt_runtime_us, self.rt_period_us) {
            (Some(-1), _) => write!(f, "RT throttling:      off (sched_rt_runtime_us = -1)"),
            (Some(rt), Some(p)) => write!(
                f,
                "RT throttling:      on: FIFO threads get {rt} µs per {p} µs ({:.0} %)",
                100.0 * rt as f64 / p as f64
            ),
            _ => write!(f, "RT throttling:      unknown"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_has_the_basics_and_prints_every_line() {
        let r = Report::gather();
        assert!(r.cpus >= 1);
        assert!(!r.cpu_list.is_empty());
        assert!(r.sched_idle.granted(), "SCHED_IDLE is always permitted");
        assert!(
            r.affinity.granted(),
            "pinning to an allowed CPU is always permitted"
        );
        assert!(matches!(r.clock_resolution_ns, Ok(ns) if ns >= 1));
        let text = r.to_string();
        for key in [
            "shared memory:",
            "SCHED_FIFO:",
            "mlockall:",
            "CPU affinity:",
            "clock resolution:",
            "cpus:",
            "RT throttling:",
            "/dev/shm",
        ] {
            assert!(text.contains(key), "missing {key} in\n{text}");
        }
        // The probes ran on scratch threads: this thread is unchanged.
        assert_eq!(crate::os::current_policy().unwrap(), libc::SCHED_OTHER);
    }
}
