//! `--link ENDPOINT...` and the zenoh configuration the tunnel's session opens with.
//!
//! An endpoint is a zenoh locator `<protocol>/<address>` (e.g. `tcp/0.0.0.0:7447`,
//! `tls/robot:7447`), optionally prefixed `listen:` or `connect:`. Without a prefix, an
//! endpoint on an unspecified address (`0.0.0.0`, `[::]`) is listened on and any other is
//! connected to: the robot runs `--link tcp/0.0.0.0:7447`, the station `--link tcp/robot:7447`.

use super::LinkError;
use std::path::Path;

/// zenoh protocols the carrier is built with (the 0.10 tunnel's feature choice).
const PROTOCOLS: [&str; 8] = [
    "tcp",
    "tls",
    "udp",
    "quic",
    "quic_datagram",
    "ws",
    "unixsock-stream",
    "vsock",
];

/// Whether the tunnel listens on an endpoint or connects to it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// Accept the other host's connections here.
    Listen,
    /// Connect to the other host there.
    Connect,
}

/// One parsed `--link` value.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Endpoint {
    /// Listen or connect.
    pub direction: Direction,
    /// The zenoh locator, `<protocol>/<address>`.
    pub locator: String,
}

/// Parse one `--link` value (see the module docs).
pub fn parse_endpoint(value: &str) -> Result<Endpoint, LinkError> {
    let bad = |why: &str| LinkError::Endpoint {
        value: value.to_string(),
        reason: why.to_string(),
    };
    let (direction, locator) = match value.split_once(':') {
        Some(("listen", rest)) => (Some(Direction::Listen), rest),
        Some(("connect", rest)) => (Some(Direction::Connect), rest),
        _ => (None, value),
    };
    let Some((protocol, address)) = locator.split_once('/') else {
        return Err(bad("expected <protocol>/<address>, e.g. tcp/0.0.0.0:7447"));
    };
    if !PROTOCOLS.contains(&protocol) {
        return Err(bad(&format!(
            "unknown protocol {protocol:?} (one of {})",
            PROTOCOLS.join(", ")
        )));
    }
    if address.is_empty() {
        return Err(bad("the address is empty"));
    }
    let unspecified = ["0.0.0.0", "[::]"]
        .iter()
        .any(|h| address == *h || address.starts_with(&format!("{h}:")));
    let direction = direction.unwrap_or(if unspecified {
        Direction::Listen
    } else {
        Direction::Connect
    });
    if direction == Direction::Connect && unspecified {
        return Err(bad("cannot connect to an unspecified address"));
    }
    Ok(Endpoint {
        direction,
        locator: locator.to_string(),
    })
}

/// The zenoh configuration of the tunnel: `file` as it is (the operator's endpoints, TLS,
/// access control), or else the built-in one (peer mode, multicast scouting off so nothing
/// on the network is joined by accident, no listener beyond the endpoints, a deeper transmit
/// queue); then the `--link` endpoints replace the configuration's listen and/or connect lists.
pub fn zenoh_config(
    file: Option<&Path>,
    endpoints: &[Endpoint],
) -> Result<zenoh::Config, LinkError> {
    let zerr = |key: &str, e: &dyn std::fmt::Display| LinkError::ZenohConfig {
        file: file.map_or_else(|| "<built-in>".into(), |f| f.display().to_string()),
        key: key.to_string(),
        reason: e.to_string(),
    };
    let mut cfg = match file {
        Some(f) => zenoh::Config::from_file(f).map_err(|e| zerr("(file)", &e))?,
        None => {
            let mut c = zenoh::Config::default();
            for (key, value) in [
                ("mode", r#""peer""#),
                ("scouting/multicast/enabled", "false"),
                ("listen/endpoints", "[]"),
                ("connect/endpoints", "[]"),
                // A run sends large fixed-size samples (a 700 KB map, a 600 KB frame) beside
                // small ones; with zenoh's defaults (2 batches of 64 KB, 1 ms before a drop) a
                // small sample queued behind a frame's fragments is dropped. 16 batches (the
                // maximum) and 20 ms: the tunnel thread may wait that long, never a node.
                ("transport/link/tx/queue/size/data", "16"),
                (
                    "transport/link/tx/queue/congestion_control/drop/wait_before_drop",
                    "20000",
                ),
            ] {
                c.insert_json5(key, value).map_err(|e| zerr(key, &e))?;
            }
            c
        }
    };
    for (direction, key) in [
        (Direction::Listen, "listen/endpoints"),
        (Direction::Connect, "connect/endpoints"),
    ] {
        let list: Vec<&str> = endpoints
            .iter()
            .filter(|e| e.direction == direction)
            .map(|e| e.locator.as_str())
            .collect();
        if !list.is_empty() {
            let json = serde_json::to_string(&list).map_err(|e| zerr(key, &e))?;
            cfg.insert_json5(key, &json).map_err(|e| zerr(key, &e))?;
        }
    }
    Ok(cfg)
}

/// The zenoh key of the tunnel's channel of the publish-subscribe service `service` (a full
/// name), any fingerprint: `iox2/v1/channel/<service hash>/*` (the key scheme of
/// `iceoryx2-integrations-zenoh-link-carrier` 0.10, `src/keys.rs`).
pub fn channel_key(service: &str) -> Result<String, LinkError> {
    use iceoryx2::prelude::{MessagingPattern, ServiceName, ipc};
    use iceoryx2::service::Service;
    use iceoryx2::service::service_hash::ServiceHash;
    let name = ServiceName::new(service)
        .map_err(|e| LinkError::Iceoryx(format!("service name {service}: {e:?}")))?;
    let hash = ServiceHash::new::<<ipc::Service as Service>::ServiceNameHasher>(
        &name,
        MessagingPattern::PublishSubscribe,
    );
    Ok(format!("iox2/v1/channel/{}/*", hash.as_str()))
}

/// zenoh's per-key QoS for the tunnel's channels (`qos/publication`), unless the configuration
/// sets its own: the services in `small` at priority `interactive_high` with congestion control
/// `block`, those in `high` at `data_high`, the rest at zenoh's `data`. Each priority has its
/// own transmit queue, so the fragments of the large samples, which fill the `data` queue when
/// zenoh's transmit thread falls behind (a loaded machine), no longer make zenoh drop the small
/// samples queued behind them (issue #35: 4-16 robot states at a time, with every other topic
/// losing the same 40-160 ms). `block` makes the tunnel thread wait for the queue, never a node.
pub fn channel_qos(
    cfg: &mut zenoh::Config,
    small: &[String],
    high: &[String],
) -> Result<(), LinkError> {
    let zerr = |key: &str, e: &dyn std::fmt::Display| LinkError::ZenohConfig {
        file: "<tunnel QoS>".into(),
        key: key.to_string(),
        reason: e.to_string(),
    };
    let key = "qos/publication";
    if cfg.get_json(key).is_ok_and(|v| v.trim() != "[]") {
        return Ok(());
    }
    let keys = |services: &[String]| -> Result<Vec<String>, LinkError> {
        services.iter().map(|s| channel_key(s)).collect()
    };
    let mut list = Vec::new();
    if !small.is_empty() {
        list.push(serde_json::json!({
            "key_exprs": keys(small)?,
            "config": { "priority": "interactive_high", "congestion_control": "block" },
        }));
    }
    if !high.is_empty() {
        list.push(serde_json::json!({
            "key_exprs": keys(high)?,
            "config": { "priority": "data_high" },
        }));
    }
    let json = serde_json::to_string(&list).map_err(|e| zerr(key, &e))?;
    cfg.insert_json5(key, &json).map_err(|e| zerr(key, &e))?;
    // The data_high queue as deep as the data queue (a 700 KB map is ~11 batches of 64 KB).
    let depth = cfg
        .get_json("transport/link/tx/queue/size/data")
        .map_err(|e| zerr("transport/link/tx/queue/size/data", &e))?;
    let high_key = "transport/link/tx/queue/size/data_high";
    if cfg.get_json(high_key).is_ok_and(|v| v.trim() == "2") {
        cfg.insert_json5(high_key, &depth)
            .map_err(|e| zerr(high_key, &e))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_issues_two_commands_listen_on_the_robot_and_connect_from_the_station() {
        assert_eq!(
            parse_endpoint("tcp/0.0.0.0:7447").unwrap(),
            Endpoint {
                direction: Direction::Listen,
                locator: "tcp/0.0.0.0:7447".into()
            }
        );
        assert_eq!(
            parse_endpoint("tcp/robot:7447").unwrap(),
            Endpoint {
                direction: Direction::Connect,
                locator: "tcp/robot:7447".into()
            }
        );
        assert_eq!(
            parse_endpoint("listen:tcp/127.0.0.1:7447")
                .unwrap()
                .direction,
            Direction::Listen
        );
        assert_eq!(
            parse_endpoint("tcp/[::]:7447").unwrap().direction,
            Direction::Listen
        );
    }

    #[test]
    fn bad_endpoints_are_errors_naming_the_value() {
        for (value, why) in [
            ("robot:7447", "expected <protocol>/<address>"),
            ("http/robot:80", "unknown protocol \"http\""),
            ("tcp/", "the address is empty"),
            (
                "connect:tcp/0.0.0.0:1",
                "cannot connect to an unspecified address",
            ),
        ] {
            let e = parse_endpoint(value).unwrap_err().to_string();
            assert!(e.contains(value) && e.contains(why), "{value}: {e}");
        }
    }

    #[test]
    fn endpoints_replace_the_lists_of_the_built_in_config() {
        let eps = [
            parse_endpoint("tcp/127.0.0.1:7000").unwrap(),
            parse_endpoint("tcp/0.0.0.0:7001").unwrap(),
        ];
        let cfg = zenoh_config(None, &eps).unwrap();
        let connect = cfg.get_json("connect/endpoints").unwrap();
        let listen = cfg.get_json("listen/endpoints").unwrap();
        assert!(connect.contains("tcp/127.0.0.1:7000"), "{connect}");
        assert!(!connect.contains("7001"), "{connect}");
        assert!(listen.contains("tcp/0.0.0.0:7001"), "{listen}");
        assert_eq!(cfg.get_json("scouting/multicast/enabled").unwrap(), "false");
    }

    #[test]
    fn the_shipped_tls_example_is_a_valid_zenoh_config_and_keeps_the_link_endpoints() {
        let file = Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/zenoh-link-tls.json5"
        ));
        let cfg = zenoh_config(Some(file), &[parse_endpoint("tls/robot:7447").unwrap()])
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(
            cfg.get_json("connect/endpoints")
                .unwrap()
                .contains("tls/robot:7447")
        );
        assert!(
            cfg.get_json("listen/endpoints")
                .unwrap()
                .contains("tls/0.0.0.0:7447")
        );
        assert_eq!(cfg.get_json("access_control/enabled").unwrap(), "true");
    }

    #[test]
    fn a_missing_zenoh_file_is_an_error_naming_it() {
        let e = zenoh_config(Some(Path::new("/nonexistent/zenoh.json5")), &[])
            .unwrap_err()
            .to_string();
        assert!(e.contains("/nonexistent/zenoh.json5"), "{e}");
    }

    #[test]
    fn the_small_topics_channels_get_their_own_priority_and_block() {
        let mut cfg = zenoh_config(None, &[]).unwrap();
        let small = ["vpsom/main/robot/state".to_string()];
        let high = ["vpsom/main/map".to_string()];
        channel_qos(&mut cfg, &small, &high).unwrap();
        let qos = cfg.get_json("qos/publication").unwrap();
        let state = channel_key(&small[0]).unwrap();
        assert!(
            state.starts_with("iox2/v1/channel/") && state.ends_with("/*"),
            "{state}"
        );
        assert!(qos.contains(&state), "{qos}");
        assert!(
            qos.contains("interactive_high") && qos.contains("block"),
            "{qos}"
        );
        assert!(qos.contains(&channel_key(&high[0]).unwrap()), "{qos}");
        assert_eq!(
            cfg.get_json("transport/link/tx/queue/size/data_high")
                .unwrap(),
            "16"
        );
        // A configuration with its own QoS keeps it.
        let mut own = zenoh::Config::default();
        own.insert_json5(
            "qos/publication",
            r#"[{"key_exprs":["a/b"],"config":{"priority":"data_low"}}]"#,
        )
        .unwrap();
        channel_qos(&mut own, &small, &high).unwrap();
        assert!(own.get_json("qos/publication").unwrap().contains("a/b"));
    }
}
