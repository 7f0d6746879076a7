//! Another user's process cannot open a run's services (issue #16 part 6), and two users
//! running the same namespace on one host stay apart ([`runtime::ports::access`]).
//!
//! Needs root, to create a second user (`useradd`) and to start a process as that user; CI
//! runs it as root with `--ignored`. Without root it fails.

use runtime::ports::{PortContext, PortsConfig, Stamp, access};
use shm_types::RobotState;
use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::os::unix::process::CommandExt;
use std::path::Path;
use std::process::Command;

/// Set in the child (the other user): the owner's uid and the namespace to attack.
const CHILD_ENV: &str = "VPSOM_ACCESS_CHILD";
const OTHER_USER: &str = "vpsom-access";
const TEST: &str = "another_user_cannot_open_a_run_and_runs_its_own_beside_it";

fn uid_of(user: &str) -> Option<(u32, u32)> {
    let out = Command::new("id").args(["-u", user]).output().ok()?;
    let uid = String::from_utf8_lossy(&out.stdout).trim().parse().ok()?;
    let out = Command::new("id").args(["-g", user]).output().ok()?;
    let gid = String::from_utf8_lossy(&out.stdout).trim().parse().ok()?;
    Some((uid, gid))
}

/// Files (not directories) under `dir`, recursively, and their modes.
fn modes(dir: &Path, out: &mut Vec<(String, u32)>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let m = e.metadata().unwrap();
        if m.is_dir() {
            modes(&e.path(), out);
        } else {
            out.push((e.path().display().to_string(), m.mode() & 0o777));
        }
    }
}

/// The other user's side: every way into the owner's run must fail, and a run of its own in
/// the same namespace must work. Returns what was refused, or the first way that got in.
fn child(owner: u32, ns: &str) -> Result<Vec<String>, String> {
    let mut refused = Vec::new();
    // 1. iceoryx2 with the owner's configuration (root directory and prefix).
    let cfg = access::config_for_user(owner);
    let name = iceoryx2::prelude::NodeName::new("intruder").unwrap();
    match iceoryx2::prelude::NodeBuilder::new()
        .name(&name)
        .config(&cfg)
        .create::<iceoryx2::prelude::ipc::Service>()
    {
        Err(e) => refused.push(format!("node in the owner's root: {e:?}")),
        Ok(node) => {
            let service = shm_types::contract::service_name(ns, "robot/state");
            let svc = iceoryx2::prelude::ServiceName::new(&service).unwrap();
            match node
                .service_builder(&svc)
                .publish_subscribe::<RobotState>()
                .open()
            {
                Ok(_) => return Err(format!("opened {service} with the owner's config")),
                Err(e) => refused.push(format!("open {service}: {e:?}")),
            }
        }
    }
    // 2. The owner's shared-memory objects, opened directly.
    let prefix = access::prefix(owner);
    for e in std::fs::read_dir("/dev/shm").unwrap().flatten() {
        let file = e.file_name().to_string_lossy().to_string();
        if !file.starts_with(&prefix) || file.ends_with("global_mgmt") {
            continue;
        }
        match std::fs::OpenOptions::new().read(true).open(e.path()) {
            Ok(_) => return Err(format!("read /dev/shm/{file}")),
            Err(err) => refused.push(format!("/dev/shm/{file}: {err}")),
        }
    }
    // 3. A run of its own in the same namespace, on the same topic.
    let ctx = PortContext::with_namespace(&PortsConfig::default(), "other-user", ns)
        .map_err(|e| format!("own context: {e}"))?;
    let publ = ctx
        .publisher::<RobotState>("robot/state")
        .map_err(|e| format!("own publisher: {e}"))?;
    let sub = ctx
        .subscriber::<RobotState>("robot/state")
        .map_err(|e| format!("own subscriber: {e}"))?;
    let mut s = publ.loan().map_err(|e| e.to_string())?;
    s.base_pose[0] = 7.0;
    s.send(Stamp::default()).map_err(|e| e.to_string())?;
    let got = sub.receive().map_err(|e| e.to_string())?;
    if got.map(|g| g.base_pose[0]) != Some(7.0) {
        return Err("own service did not deliver".into());
    }
    Ok(refused)
}

#[test]
#[ignore = "needs root to create a second user"]
fn another_user_cannot_open_a_run_and_runs_its_own_beside_it() {
    if let Ok(v) = std::env::var(CHILD_ENV) {
        let (owner, ns) = v.split_once(':').unwrap();
        match child(owner.parse().unwrap(), ns) {
            Ok(refused) => {
                assert!(refused.len() >= 2, "{refused:?}");
                for r in refused {
                    println!("refused: {r}");
                }
                return;
            }
            Err(e) => panic!("the other user got in: {e}"),
        }
    }
    let me = access::current_user();
    assert_eq!(me, 0, "needs root (to create the user {OTHER_USER})");
    if uid_of(OTHER_USER).is_none() {
        let ok = Command::new("useradd")
            .args([
                "--system",
                "--no-create-home",
                "--shell",
                "/usr/sbin/nologin",
            ])
            .arg(OTHER_USER)
            .status()
            .unwrap()
            .success();
        assert!(ok, "useradd {OTHER_USER} failed");
    }
    let (uid, gid) = uid_of(OTHER_USER).unwrap();

    // The owner's run: a publisher with one sample on robot/state.
    let ns = format!("access{}", std::process::id());
    let ctx = PortContext::with_namespace(&PortsConfig::default(), "owner", &ns).unwrap();
    let publ = ctx.publisher::<RobotState>("robot/state").unwrap();
    let _sub = ctx.subscriber::<RobotState>("robot/state").unwrap();
    publ.loan().unwrap().send(Stamp::default()).unwrap();

    // Everything of it is owner-only: the root directory 0700 (iceoryx2's directories below it
    // are 0750, unreachable through it), every file below it, and its shared-memory objects
    // (but iceoryx2's 16-byte global management segment).
    let root = access::root_path(me);
    let m = std::fs::metadata(&root).unwrap();
    assert_eq!(m.permissions().mode() & 0o777, 0o700, "{}", root.display());
    let mut files = Vec::new();
    modes(&root, &mut files);
    let prefix = access::prefix(me);
    for e in std::fs::read_dir("/dev/shm").unwrap().flatten() {
        let file = e.file_name().to_string_lossy().to_string();
        if file.starts_with(&prefix) && !file.ends_with("global_mgmt") {
            files.push((file, e.metadata().unwrap().mode() & 0o777));
        }
    }
    assert!(files.len() > 4, "{files:?}");
    let open: Vec<_> = files.iter().filter(|(_, m)| m & 0o077 != 0).collect();
    assert!(open.is_empty(), "not owner-only: {open:?}");

    // The other user tries (this test binary, copied where that user can run it).
    let dir = std::env::temp_dir().join(format!("vpsom-access-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o755)).unwrap();
    let exe = dir.join("access-test");
    std::fs::copy(std::env::current_exe().unwrap(), &exe).unwrap();
    std::fs::set_permissions(&exe, std::fs::Permissions::from_mode(0o755)).unwrap();
    let out = Command::new(&exe)
        .args([
            "--exact",
            TEST,
            "--ignored",
            "--nocapture",
            "--test-threads=1",
        ])
        .env(CHILD_ENV, format!("{me}:{ns}"))
        .current_dir(&dir)
        .uid(uid)
        .gid(gid)
        .output()
        .unwrap();
    let text = format!(
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "the other user's process:\n{text}");
    assert!(text.contains("refused: "), "{text}");
    println!("{text}");
    let _ = std::fs::remove_dir_all(&dir);
}
