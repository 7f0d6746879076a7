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
}
