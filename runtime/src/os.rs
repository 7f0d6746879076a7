//! The narrow module where runtime makes OS calls (scheduling, memory locking, affinity, clocks).
//! It is the only place in `runtime` with `unsafe`; every call returns `io::Result` and touches
//! only the calling thread unless documented otherwise (Linux applies scheduling attributes given
//! pid/tid 0 or a tid to that one thread).
#![allow(unsafe_code)]

use std::io;

/// `Ok(())` if a libc call returned 0, else the thread's `errno`.
fn check(ret: libc::c_int) -> io::Result<()> {
    if ret == 0 {
        Ok(())
    } else {
        Err(io::Error::last_os_error())
    }
}

/// The kernel thread id of the calling thread.
pub fn gettid() -> libc::pid_t {
    // SAFETY: `gettid` takes no arguments, cannot fail and has no memory effects.
    unsafe { libc::gettid() }
}

/// The calling process's effective user id.
pub fn euid() -> u32 {
    // SAFETY: geteuid has no preconditions and cannot fail.
    unsafe { libc::geteuid() }
}

/// Set the calling thread to `SCHED_FIFO` at `priority` (1..=99). EPERM without CAP_SYS_NICE or
/// an RLIMIT_RTPRIO allowance.
pub fn set_fifo(priority: i32) -> io::Result<()> {
    set_policy(libc::SCHED_FIFO, priority)
}

/// Set the calling thread back to `SCHED_OTHER` (priority 0).
pub fn set_other() -> io::Result<()> {
    set_policy(libc::SCHED_OTHER, 0)
}

/// Set the calling thread to `SCHED_IDLE` (runs only when nothing else wants the CPU).
pub fn set_idle() -> io::Result<()> {
    set_policy(libc::SCHED_IDLE, 0)
}

/// `struct sched_attr` of `sched_setattr(2)` (not in `libc`).
#[repr(C)]
struct SchedAttr {
    size: u32,
    sched_policy: u32,
    sched_flags: u64,
    sched_nice: i32,
    sched_priority: u32,
    sched_runtime: u64,
    sched_deadline: u64,
    sched_period: u64,
}

/// `SCHED_DEADLINE` (not in `libc`).
const SCHED_DEADLINE: u32 = 6;

/// Set the calling thread to `SCHED_DEADLINE`: `runtime_ns` of CPU in every `period_ns`, due by
/// the end of the period. Needs CAP_SYS_NICE, a thread allowed on every CPU of its root domain,
/// and free deadline bandwidth (admission control: EBUSY).
pub fn set_deadline(runtime_ns: u64, period_ns: u64) -> io::Result<()> {
    let attr = SchedAttr {
        size: std::mem::size_of::<SchedAttr>() as u32,
        sched_policy: SCHED_DEADLINE,
        sched_flags: 0,
        sched_nice: 0,
        sched_priority: 0,
        sched_runtime: runtime_ns,
        sched_deadline: period_ns,
        sched_period: period_ns,
    };
    // SAFETY: `attr` is a valid, initialised `sched_attr` whose `size` field says how large it
    // is; pid 0 means the calling thread; flags 0; the kernel only reads the struct.
    let r = unsafe { libc::syscall(libc::SYS_sched_setattr, 0, &attr as *const SchedAttr, 0) };
    if r == 0 {
        Ok(())
    } else {
        Err(io::Error::last_os_error())
    }
}

fn set_policy(policy: libc::c_int, priority: i32) -> io::Result<()> {
    let param = libc::sched_param {
        sched_priority: priority,
    };
    // SAFETY: `param` is a valid, initialised `sched_param` that outlives the call; pid 0 means
    // the calling thread; the kernel only reads the struct.
    check(unsafe { libc::sched_setscheduler(0, policy, &param) })
}

/// Highest `SCHED_FIFO` priority (99 on Linux).
pub fn fifo_max_priority() -> i32 {
    // SAFETY: no pointers, no side effects.
    unsafe { libc::sched_get_priority_max(libc::SCHED_FIFO) }
}

/// Scheduling policy of the calling thread (`libc::SCHED_*`).
#[cfg(test)]
pub fn current_policy() -> io::Result<libc::c_int> {
    // SAFETY: no pointers; pid 0 means the calling thread.
    let p = unsafe { libc::sched_getscheduler(0) };
    if p < 0 {
        Err(io::Error::last_os_error())
    } else {
        Ok(p)
    }
}

/// Set the nice value (-20..=19) of the calling thread only.
pub fn set_nice(nice: i32) -> io::Result<()> {
    // SAFETY: no pointers; on Linux `PRIO_PROCESS` with a thread id changes that one thread.
    check(unsafe { libc::setpriority(libc::PRIO_PROCESS, gettid() as libc::id_t, nice) })
}

/// Nice value of the calling thread.
pub fn nice() -> io::Result<i32> {
    // `getpriority` may legitimately return -1, so errno must be cleared and checked.
    // SAFETY: `__errno_location` returns the calling thread's errno slot, valid for writes.
    unsafe { *libc::__errno_location() = 0 };
    // SAFETY: no pointers; a thread id with PRIO_PROCESS reads that thread's nice value.
    let n = unsafe { libc::getpriority(libc::PRIO_PROCESS, gettid() as libc::id_t) };
    let err = io::Error::last_os_error();
    if n == -1 && err.raw_os_error().unwrap_or(0) != 0 {
        Err(err)
    } else {
        Ok(n)
    }
}

/// Lock all current and future pages of the **process** in RAM (`MCL_CURRENT | MCL_FUTURE`).
pub fn mlockall() -> io::Result<()> {
    // SAFETY: no pointers; only changes the paging of this process.
    check(unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) })
}

/// Lock only the current pages of the process (used by `doctor` as a probe).
pub fn mlockall_current() -> io::Result<()> {
    // SAFETY: no pointers; only changes the paging of this process.
    check(unsafe { libc::mlockall(libc::MCL_CURRENT) })
}

/// Undo [`mlockall`] for the whole process.
pub fn munlockall() -> io::Result<()> {
    // SAFETY: no pointers; only changes the paging of this process.
    check(unsafe { libc::munlockall() })
}

/// Ask the kernel to keep every CPU's wake-up latency at most `us` µs (power management may
/// not use deeper idle states) for as long as the returned file stays open, as cyclictest does.
/// On a VM with the `haltpoll` idle driver, 0 makes idle vCPUs poll instead of halting.
pub fn hold_cpu_dma_latency(us: i32) -> io::Result<std::fs::File> {
    use std::io::Write;
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/cpu_dma_latency")?;
    f.write_all(&us.to_ne_bytes())?;
    Ok(f)
}

/// The scheduler statistics of one thread (`/proc/thread-self/schedstat`, opened by that thread
/// and read in place with `pread`: no allocation, one syscall per read).
#[derive(Debug)]
pub struct ThreadSchedStat {
    file: std::fs::File,
}

/// One reading of [`ThreadSchedStat`], cumulative since the thread started.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SchedStatReading {
    /// Time spent on a CPU, ns.
    pub cpu_ns: u64,
    /// Time spent runnable, waiting on a run queue, ns.
    pub run_wait_ns: u64,
    /// Times the thread was put on a CPU.
    pub timeslices: u64,
}

impl ThreadSchedStat {
    /// Open the calling thread's statistics (the file stays bound to this thread). `Err` if the
    /// kernel does not provide them (no `CONFIG_SCHED_INFO`, or no `/proc`).
    pub fn open_current() -> io::Result<Self> {
        let file = std::fs::File::open("/proc/thread-self/schedstat")?;
        let s = Self { file };
        s.read()?;
        Ok(s)
    }

    /// The current reading.
    pub fn read(&self) -> io::Result<SchedStatReading> {
        use std::os::unix::fs::FileExt;
        let mut buf = [0u8; 96];
        let n = self.file.read_at(&mut buf, 0)?;
        parse_schedstat(&buf[..n]).ok_or_else(|| {
            io::Error::new(
                io::ErrorKind::InvalidData,
                "unexpected /proc/thread-self/schedstat format",
            )
        })
    }
}

/// `"<cpu ns> <run-queue wait ns> <timeslices>\n"`.
fn parse_schedstat(b: &[u8]) -> Option<SchedStatReading> {
    let mut f = std::str::from_utf8(b)
        .ok()?
        .split_ascii_whitespace()
        .map(|x| x.parse::<u64>().ok());
    Some(SchedStatReading {
        cpu_ns: f.next()??,
        run_wait_ns: f.next()??,
        timeslices: f.next()??,
    })
}

/// Pin the calling thread to `cpus` (indices). EINVAL if none of them exists.
pub fn set_affinity(cpus: &[usize]) -> io::Result<()> {
    set_thread_affinity(0, cpus)
}

/// Pin thread `tid` of this process (0 = the calling thread) to `cpus`. EINVAL if none of
/// them exists.
pub fn set_thread_affinity(tid: libc::pid_t, cpus: &[usize]) -> io::Result<()> {
    // SAFETY: an all-zero `cpu_set_t` is the empty set (it is a plain bit array).
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    let max = 8 * std::mem::size_of::<libc::cpu_set_t>();
    for &c in cpus {
        if c >= max {
            return Err(io::Error::from_raw_os_error(libc::EINVAL));
        }
        // SAFETY: `c` is below the set's capacity (checked above); `set` is a valid cpu_set_t.
        unsafe { libc::CPU_SET(c, &mut set) };
    }
    // SAFETY: `set` is a valid cpu_set_t of the size passed; the kernel only reads it.
    check(unsafe { libc::sched_setaffinity(tid, std::mem::size_of::<libc::cpu_set_t>(), &set) })
}

/// Sleep while `word` holds `expected`, until `CLOCK_MONOTONIC` reaches `deadline_ns`
/// (absolute) or [`futex_wake`] is called on `word`. Returns on a wake-up, a timeout, a signal or
/// if `word` no longer held `expected`; the caller re-checks its condition.
pub fn futex_wait_until(word: &std::sync::atomic::AtomicU32, expected: u32, deadline_ns: u64) {
    let ts = libc::timespec {
        tv_sec: (deadline_ns / 1_000_000_000) as libc::time_t,
        tv_nsec: (deadline_ns % 1_000_000_000) as libc::c_long,
    };
    // SAFETY: `word` is a valid, aligned 32-bit atomic that outlives the call; `ts` is a valid
    // timespec; FUTEX_WAIT_BITSET takes an absolute CLOCK_MONOTONIC timeout; the unused
    // second address is null. The result needs no handling: every outcome (woken, ETIMEDOUT,
    // EAGAIN, EINTR) sends the caller back to its own check.
    unsafe {
        libc::syscall(
            libc::SYS_futex,
            word.as_ptr(),
            libc::FUTEX_WAIT_BITSET | libc::FUTEX_PRIVATE_FLAG,
            expected,
            &ts as *const libc::timespec,
            std::ptr::null::<u32>(),
            libc::FUTEX_BITSET_MATCH_ANY,
        )
    };
}

/// Wake the threads sleeping in [`futex_wait_until`] on `word`.
pub fn futex_wake(word: &std::sync::atomic::AtomicU32) {
    // SAFETY: `word` is a valid, aligned 32-bit atomic; FUTEX_WAKE only reads the address.
    unsafe {
        libc::syscall(
            libc::SYS_futex,
            word.as_ptr(),
            libc::FUTEX_WAKE | libc::FUTEX_PRIVATE_FLAG,
            i32::MAX,
        )
    };
}

/// The CPUs the calling thread may run on.
pub fn affinity() -> io::Result<Vec<usize>> {
    thread_affinity(0)
}

/// The CPUs the process's main thread may run on: what threads get unless they are pinned.
pub fn process_affinity() -> io::Result<Vec<usize>> {
    // SAFETY: `getpid` takes no arguments and cannot fail.
    thread_affinity(unsafe { libc::getpid() })
}

/// The CPUs thread `tid` of this process (0 = the calling thread) may run on.
fn thread_affinity(tid: libc::pid_t) -> io::Result<Vec<usize>> {
    // SAFETY: an all-zero `cpu_set_t` is the empty set.
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    // SAFETY: `set` is a valid, writable cpu_set_t of the size passed; the kernel writes it.
    check(unsafe {
        libc::sched_getaffinity(tid, std::mem::size_of::<libc::cpu_set_t>(), &mut set)
    })?;
    let max = 8 * std::mem::size_of::<libc::cpu_set_t>();
    // SAFETY: every index is below the set's capacity; `set` was filled by the kernel.
    Ok((0..max)
        .filter(|&c| unsafe { libc::CPU_ISSET(c, &set) })
        .collect())
}

/// `CLOCK_MONOTONIC` now, nanoseconds.
pub fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; CLOCK_MONOTONIC always exists on Linux, so
    // the call cannot fail (EFAULT/EINVAL are impossible here).
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// Sleep until `CLOCK_MONOTONIC` reaches `deadline_ns` (absolute, `TIMER_ABSTIME`), resuming
/// after signal interruptions. Returns at once if the deadline has passed.
pub fn sleep_until_ns(deadline_ns: u64) -> io::Result<()> {
    let ts = libc::timespec {
        tv_sec: (deadline_ns / 1_000_000_000) as libc::time_t,
        tv_nsec: (deadline_ns % 1_000_000_000) as libc::c_long,
    };
    loop {
        // SAFETY: `ts` is a valid timespec; with TIMER_ABSTIME the remaining-time pointer is
        // unused and may be null.
        let r = unsafe {
            libc::clock_nanosleep(
                libc::CLOCK_MONOTONIC,
                libc::TIMER_ABSTIME,
                &ts,
                std::ptr::null_mut(),
            )
        };
        match r {
            0 => return Ok(()),
            libc::EINTR => continue,
            e => return Err(io::Error::from_raw_os_error(e)),
        }
    }
}

/// Resolution of `CLOCK_MONOTONIC`, nanoseconds.
pub fn monotonic_resolution_ns() -> io::Result<u64> {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec.
    check(unsafe { libc::clock_getres(libc::CLOCK_MONOTONIC, &mut ts) })?;
    Ok(ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64)
}

/// `access(path, R_OK | W_OK | X_OK)`: the calling user may create files in directory `path`.
pub fn dir_writable(path: &std::path::Path) -> io::Result<()> {
    use std::os::unix::ffi::OsStrExt;
    let c = std::ffi::CString::new(path.as_os_str().as_bytes())
        .map_err(|_| io::Error::from_raw_os_error(libc::EINVAL))?;
    // SAFETY: `c` is a NUL-terminated path that outlives the call; access only reads it.
    check(unsafe { libc::access(c.as_ptr(), libc::R_OK | libc::W_OK | libc::X_OK) })
}

/// Size and free space (bytes available to this user) of the filesystem holding `path`.
pub fn fs_space(path: &std::path::Path) -> io::Result<(u64, u64)> {
    use std::os::unix::ffi::OsStrExt;
    let c = std::ffi::CString::new(path.as_os_str().as_bytes())
        .map_err(|_| io::Error::from_raw_os_error(libc::EINVAL))?;
    // SAFETY: an all-zero `statvfs` is a valid value of this plain C struct.
    let mut st: libc::statvfs = unsafe { std::mem::zeroed() };
    // SAFETY: `c` is a NUL-terminated path that outlives the call; `st` is valid and writable.
    check(unsafe { libc::statvfs(c.as_ptr(), &mut st) })?;
    let frsize = st.f_frsize as u64;
    Ok((st.f_blocks as u64 * frsize, st.f_bavail as u64 * frsize))
}

/// Make `cmd`'s child start with the default action for SIGINT and SIGTERM, the signals a
/// launcher stops it with. A process started in the background by a non-interactive shell
/// (`vpsom run ... &` in a script, `nohup`) has SIGINT ignored, and an ignored signal is
/// inherited across `exec` and cannot even be trapped by `sh`: its children would only ever
/// end by SIGKILL, a recorder without finishing its file.
pub fn default_stop_signals_on_exec(cmd: &mut std::process::Command) {
    use std::os::unix::process::CommandExt;
    // SAFETY: between fork and exec only `signal`, which is async-signal-safe, is called.
    unsafe {
        cmd.pre_exec(|| {
            for sig in [libc::SIGINT, libc::SIGTERM] {
                if libc::signal(sig, libc::SIG_DFL) == libc::SIG_ERR {
                    return Err(io::Error::last_os_error());
                }
            }
            Ok(())
        });
    }
}

/// Send signal `sig` (e.g. `libc::SIGINT`) to process `pid`.
pub fn send_signal(pid: u32, sig: i32) -> io::Result<()> {
    let pid =
        libc::pid_t::try_from(pid).map_err(|_| io::Error::from(io::ErrorKind::InvalidInput))?;
    // SAFETY: kill(2) takes plain integers and has no memory-safety preconditions.
    check(unsafe { libc::kill(pid, sig) })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schedstat_is_parsed_and_counts_this_threads_cpu_time() {
        let r = parse_schedstat(b"123 45 6\n").unwrap();
        assert_eq!((r.cpu_ns, r.run_wait_ns, r.timeslices), (123, 45, 6));
        assert_eq!(parse_schedstat(b"123 45\n"), None);
        assert_eq!(parse_schedstat(b"x 45 6\n"), None);
        // The file is bound to the thread that opened it: another thread's spinning does not
        // show up in it, this thread's does.
        let Ok(stat) = ThreadSchedStat::open_current() else {
            return; // kernel without per-thread scheduler statistics
        };
        let a = stat.read().unwrap();
        std::thread::spawn(|| spin_cpu_ms(30)).join().unwrap();
        let b = stat.read().unwrap();
        spin_cpu_ms(30);
        let c = stat.read().unwrap();
        assert!(b.cpu_ns - a.cpu_ns < 20_000_000, "{a:?} {b:?}");
        assert!(c.cpu_ns - b.cpu_ns >= 29_000_000, "{b:?} {c:?}");
    }

    /// Busy-loop until the calling thread has used `ms` of CPU time.
    fn spin_cpu_ms(ms: u64) {
        let cpu = || {
            let mut ts = libc::timespec {
                tv_sec: 0,
                tv_nsec: 0,
            };
            // SAFETY: `ts` is a valid, writable timespec.
            unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
            ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
        };
        let t = cpu();
        while cpu() < t + ms * 1_000_000 {
            std::hint::spin_loop();
        }
    }

    #[test]
    fn clock_is_monotonic_and_sleep_reaches_deadline() {
        let t0 = monotonic_ns();
        sleep_until_ns(t0 + 1_000_000).unwrap();
        assert!(monotonic_ns() >= t0 + 1_000_000);
        // A deadline in the past returns at once.
        sleep_until_ns(t0).unwrap();
        let res = monotonic_resolution_ns().unwrap();
        assert!((1..=10_000_000).contains(&res), "{res}");
    }

    #[test]
    fn affinity_roundtrip_and_nice_on_scratch_thread() {
        std::thread::spawn(|| {
            let cpus = affinity().unwrap();
            assert!(!cpus.is_empty());
            set_affinity(&cpus[..1]).unwrap();
            assert_eq!(affinity().unwrap(), vec![cpus[0]]);
            // Raising one's own nice value is always permitted.
            set_nice(19).unwrap();
            assert_eq!(nice().unwrap(), 19);
            assert!(set_affinity(&[100_000]).is_err());
        })
        .join()
        .unwrap();
    }

    #[test]
    fn idle_policy_is_always_permitted() {
        std::thread::spawn(|| {
            set_idle().unwrap();
            assert_eq!(current_policy().unwrap(), libc::SCHED_IDLE);
        })
        .join()
        .unwrap();
    }
}
