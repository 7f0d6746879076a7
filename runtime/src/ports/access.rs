//! Who may open a run's services. Every user has an iceoryx2 instance of its own, so two users
//! on one host never meet, and another user's process cannot open a user's services:
//! - the root directory (static service and node records) is `/tmp/vpsom-iox2-u<uid>/`
//!   ([`root_path`]), created `0700` (iceoryx2 itself would make it `0750`; its default,
//!   `/tmp/iceoryx2/`, is shared, and the first user to create it locks every other user out);
//! - every shared-memory object and socket is named with the prefix `vpsom_u<uid>_` ([`prefix`]),
//!   so the names of two users' services never collide in `/dev/shm`;
//! - iceoryx2 0.10 (built without its `dev_permissions` feature) creates those objects
//!   owner-only: dynamic storage and data segments `0600`, static records `0400`, sockets
//!   `0600`. The one exception is its 16-byte global management segment (`0666` by design).
//!
//! Within one user, runs are kept apart by the namespace (`vpsom/<namespace>/<topic>`): two
//! robots on one host use two namespaces.
//!
//! A driver in another language must use the same two settings (the generated Python module's
//! `iceoryx2_config()` does; in C/C++ set `global.prefix` and `global.root-path` to
//! `VPSOM_IOX2_PREFIX_FMT` / `VPSOM_IOX2_ROOT_FMT` formatted with the uid).

use iceoryx2::prelude::SemanticString;
use iceoryx2_bb_system_types::file_name::FileName;
use iceoryx2_bb_system_types::path::Path as IoxPath;
use std::os::unix::fs::{DirBuilderExt, MetadataExt, PermissionsExt};
use std::path::PathBuf;

/// The effective uid of this process (whose services [`super::iceoryx2_config`] opens).
pub fn current_user() -> u32 {
    crate::os::euid()
}

/// The iceoryx2 root directory of user `uid`.
pub fn root_path(uid: u32) -> PathBuf {
    PathBuf::from(shm_types::contract::iceoryx2_root_path(uid))
}

/// The prefix of every iceoryx2 file and shared-memory object of user `uid`.
pub fn prefix(uid: u32) -> String {
    shm_types::contract::iceoryx2_prefix(uid)
}

/// The iceoryx2 configuration of user `uid`: iceoryx2's defaults with that user's root
/// directory and prefix.
pub fn config_for_user(uid: u32) -> iceoryx2::config::Config {
    let mut c = iceoryx2::config::Config::default();
    let root = shm_types::contract::iceoryx2_root_path(uid);
    // Both are short ASCII strings of digits, letters, '_', '-' and '/': always valid.
    if let Ok(p) = IoxPath::new(root.as_bytes()) {
        c.global.set_root_path(&p);
    }
    if let Ok(f) = FileName::new(prefix(uid).as_bytes()) {
        c.global.prefix = f;
    }
    c
}

/// Make the calling user's root directory exist with mode `0700` (a failure is left to
/// iceoryx2, which then reports it when it creates the node).
pub(super) fn ensure_private_root(uid: u32) {
    let dir = root_path(uid);
    match std::fs::metadata(&dir) {
        Ok(m) if m.uid() == uid && m.mode() & 0o077 != 0 => {
            let _ = std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700));
        }
        Ok(_) => {}
        Err(_) => {
            let _ = std::fs::DirBuilder::new()
                .mode(0o700)
                .recursive(true)
                .create(&dir);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_user_has_its_own_root_and_prefix() {
        let a = config_for_user(1000);
        let b = config_for_user(1001);
        assert_eq!(a.global.root_path().to_string(), "/tmp/vpsom-iox2-u1000/");
        assert_eq!(a.global.prefix.to_string(), "vpsom_u1000_");
        assert_ne!(a.global.root_path(), b.global.root_path());
        assert_ne!(a.global.prefix, b.global.prefix);
    }
}
