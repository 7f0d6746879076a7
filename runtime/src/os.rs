//! The narrow module where runtime makes OS calls (scheduling, memory locking, affinity, clocks).
#![allow(unsafe_code)]

use std::io;

/// Send signal `sig` (e.g. `libc::SIGINT`) to process `pid`.
pub fn send_signal(pid: u32, sig: i32) -> io::Result<()> {
    let pid =
        libc::pid_t::try_from(pid).map_err(|_| io::Error::from(io::ErrorKind::InvalidInput))?;
    // SAFETY: kill(2) takes plain integers and has no memory-safety preconditions.
    let rc = unsafe { libc::kill(pid, sig) };
    if rc == 0 {
        Ok(())
    } else {
        Err(io::Error::last_os_error())
    }
}
