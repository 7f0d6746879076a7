//! Benchmark payloads of fixed total size (64 B, 8 KiB, 600 KiB, 4 MiB) for the `ipc` test, plus
//! the one OS call the harness needs that has no safe wrapper (`kill(pid, SIGINT)`).
//!
//! This is the only module of `rt_tests` that allows `unsafe`: the payloads derive iceoryx2's
//! `ZeroCopySend` and bytemuck's `AnyBitPattern` (which make `shm_types::ZeroValid` and
//! `shm_types::AnyBitPattern`; both derives expand to an `unsafe impl` after checking every
//! field). Each payload is `#[repr(C)]`: a [`Header`] (three `u64`) followed by a byte array, so
//! every bit pattern is a valid value and the type holds no pointers.

use iceoryx2::prelude::ZeroCopySend;
use shm_types::{Header, Message, Validate, ValidationError};
use std::fmt;

macro_rules! payload {
    ($name:ident, $type_name:literal, $total:expr) => {
        /// A benchmark message of this total size in bytes (header included). (`Copy` because
        /// `bytemuck::AnyBitPattern` requires it; never copied by value.)
        #[derive(Clone, Copy, ZeroCopySend, bytemuck::AnyBitPattern)]
        #[repr(C)]
        #[type_name($type_name)]
        pub struct $name {
            /// Header (stamped by the publisher).
            pub header: Header,
            /// Filler.
            pub data: [u8; $total - std::mem::size_of::<Header>()],
        }

        impl Message for $name {
            fn header(&self) -> &Header {
                &self.header
            }
            fn header_mut(&mut self) -> &mut Header {
                &mut self.header
            }
        }

        /// Filler bytes: every value is valid.
        impl Validate for $name {
            fn validate(&self) -> Result<(), ValidationError> {
                Ok(())
            }
        }

        impl fmt::Debug for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.debug_struct(stringify!($name))
                    .field("header", &self.header)
                    .field("bytes", &$total)
                    .finish()
            }
        }
    };
}

payload!(Bytes64, "vpsom_rt_tests::Bytes64", 64);
payload!(Bytes8K, "vpsom_rt_tests::Bytes8K", 8 * 1024);
payload!(Bytes600K, "vpsom_rt_tests::Bytes600K", 600 * 1024);
payload!(Bytes4M, "vpsom_rt_tests::Bytes4M", 4 * 1024 * 1024);

/// Send `SIGINT` to process `pid` (a child we spawned); `Err` if the OS refuses.
pub fn send_sigint(pid: u32) -> std::io::Result<()> {
    let pid = libc::pid_t::try_from(pid)
        .map_err(|_| std::io::Error::new(std::io::ErrorKind::InvalidInput, "pid out of range"))?;
    // SAFETY: `kill` has no memory-safety preconditions; `pid` is a positive process id.
    let rc = unsafe { libc::kill(pid, libc::SIGINT) };
    if rc == 0 {
        Ok(())
    } else {
        Err(std::io::Error::last_os_error())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn payload_sizes_are_exact() {
        assert_eq!(std::mem::size_of::<Bytes64>(), 64);
        assert_eq!(std::mem::size_of::<Bytes8K>(), 8192);
        assert_eq!(std::mem::size_of::<Bytes600K>(), 614_400);
        assert_eq!(std::mem::size_of::<Bytes4M>(), 4_194_304);
        let b = shm_types::boxed_zeroed::<Bytes8K>();
        assert_eq!(b.header().seq, 0);
    }
}
