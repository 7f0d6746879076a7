//! `[ports]` configuration: [`PortsConfig`] (defaults for every topic plus per-topic
//! [`TopicOverride`]s), the resolved [`TopicSettings`] of one topic, [`Overflow`], and the name
//! checks for namespaces and topics.

use crate::config::{Checker, ConfigError};
use serde::Deserialize;
use std::collections::BTreeMap;

/// What a publisher does when a subscriber's buffer is full.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Overflow {
    /// Latest wins: the oldest unread sample in the subscriber's buffer is replaced; the
    /// publisher never blocks (real-time producers, sensor streams).
    Overwrite,
    /// Backpressure: the publisher retries until the subscriber has room (or `block_timeout_ms`
    /// passes, then `send` fails); nothing is lost (recording, tests). A subscriber attaches its
    /// end of the connection on its first `receive`/`wait`; until then a full buffer drops
    /// (iceoryx2 refuses to block on a receiver that is not attached).
    Block,
    /// The new sample is not delivered to a full subscriber; the publisher never blocks.
    Discard,
}

/// Declares every per-topic service setting once, as `field: type`, and derives from that list
/// [`TopicSettings`] (resolved values), [`TopicOverride`] (the same keys, each optional),
/// [`PortsConfig`] (`namespace`, the same keys as every topic's defaults, and `topics`) and the
/// merge `PortsConfig::settings_with`. The defaults are the `[ports]` section of
/// `config/runtime.toml` (`PortsConfig::default()`).
macro_rules! topic_settings {
    ($( $(#[doc = $doc:literal])+ $field:ident: $ty:ty, )+) => {
        /// Settings of one topic's services (the `[ports]` defaults merged with a per-topic
        /// override).
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub struct TopicSettings {
            $( $(#[doc = $doc])+ pub $field: $ty, )+
        }

        /// A per-topic override in `[ports.topics.<topic>]`; every key is optional.
        #[derive(Debug, Clone, Default, PartialEq, Eq, Deserialize)]
        #[serde(deny_unknown_fields, default)]
        pub struct TopicOverride {
            $(
                #[doc = concat!("See [`TopicSettings::", stringify!($field), "`].")]
                pub $field: Option<$ty>,
            )+
        }

        /// `[ports]` section: iceoryx2 service settings shared by every topic, plus per-topic
        /// overrides.
        #[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
        #[serde(deny_unknown_fields)]
        pub struct PortsConfig {
            /// Middle part of every service name, `vpsom/<namespace>/<topic>`: runs with
            /// different namespaces never collide. `[A-Za-z0-9_-]`, 1..=48 characters.
            pub namespace: String,
            /// The iceoryx2 domain: "" is iceoryx2's default; a name (`[A-Za-z0-9]`, up to 16)
            /// gives its own shared-memory file prefix (see [`domain_prefix`]), so processes of
            /// two domains on one machine share no shared memory.
            pub domain: String,
            $(
                #[doc = concat!("See [`TopicSettings::", stringify!($field), "`].")]
                pub $field: $ty,
            )+
            /// Per-topic overrides, keyed by topic name.
            pub topics: BTreeMap<String, TopicOverride>,
        }

        impl PortsConfig {
            /// The defaults merged with `o`.
            fn settings_with(&self, o: &TopicOverride) -> TopicSettings {
                TopicSettings {
                    $( $field: o.$field.unwrap_or(self.$field), )+
                }
            }
        }
    };
}

topic_settings! {
    /// Samples a late-joining subscriber receives on connection.
    history_size: usize,
    /// Unread samples a subscriber can buffer.
    subscriber_buffer: usize,
    /// Samples a subscriber can hold borrowed at once.
    subscriber_max_borrowed: usize,
    /// Samples a publisher can hold loaned at once.
    publisher_max_loaned: usize,
    /// Publishers per topic.
    max_publishers: usize,
    /// Subscribers per topic.
    max_subscribers: usize,
    /// Nodes (processes) that may open the topic.
    max_nodes: usize,
    /// Full-buffer behaviour.
    overflow: Overflow,
    /// With [`Overflow::Block`]: give up after this long (ms).
    block_timeout_ms: u64,
}

impl Default for PortsConfig {
    /// The `[ports]` section of the built-in `config/runtime.toml`, with its per-topic
    /// overrides (`[ports.topics.<topic>]`).
    fn default() -> Self {
        crate::config::RUNTIME_DEFAULTS.section("ports")
    }
}

impl PortsConfig {
    /// Range-check the `[ports]` section and its `[ports.topics.<topic>]` tables.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        let c = &c.at("ports");
        check_namespace(&self.namespace)
            .map_err(|why| c.range(&settings::key!(c, namespace), &self.namespace, why))?;
        check_domain(&self.domain)
            .map_err(|why| c.range(&settings::key!(c, domain), &self.domain, why))?;
        check_settings(c, &self.settings_with(&TopicOverride::default()))?;
        let topics = c.at(stringify!(topics));
        for (topic, o) in &self.topics {
            check_topic(topic).map_err(|why| c.range(&settings::key!(c, topics), topic, why))?;
            check_settings(&topics.at(topic), &self.settings_with(o))?;
        }
        Ok(())
    }

    /// The settings for `topic`: the defaults merged with `[ports.topics.<topic>]` if present.
    pub fn topic(&self, topic: &str) -> TopicSettings {
        match self.topics.get(topic) {
            Some(o) => self.settings_with(o),
            None => self.settings_with(&TopicOverride::default()),
        }
    }
}

/// Range-check one topic's settings; `c` is at `[ports]` or at `[ports.topics.<topic>]`.
fn check_settings(c: &Checker, s: &TopicSettings) -> Result<(), ConfigError> {
    settings::ranges!(c, s, {
        history_size: count(0, 64),
        subscriber_buffer: count(1, 256),
        [subscriber_max_borrowed, publisher_max_loaned]: count(1, 64),
        [max_publishers, max_subscribers]: count(1, 64),
        max_nodes: count(2, 256),
        block_timeout_ms: within(1, 600_000),
    });
    Ok(())
}

/// `Ok` if `s` is usable as one segment of a service name.
pub(super) fn check_namespace(s: &str) -> Result<(), &'static str> {
    let ok_chars = s
        .chars()
        .all(|ch| ch.is_ascii_alphanumeric() || ch == '_' || ch == '-');
    if s.is_empty() || s.len() > 48 || !ok_chars {
        Err("must be 1..=48 characters of [A-Za-z0-9_-]")
    } else {
        Ok(())
    }
}

/// `Ok` if `s` names an iceoryx2 domain: empty (iceoryx2's default) or 1..=16 ASCII letters
/// and digits (no separator, so no domain's prefix is the start of another's).
pub fn check_domain(s: &str) -> Result<(), &'static str> {
    if s.len() <= 16 && s.chars().all(|ch| ch.is_ascii_alphanumeric()) {
        Ok(())
    } else {
        Err("must be empty or 1..=16 characters of [A-Za-z0-9]")
    }
}

/// The iceoryx2 file prefix of `domain` (checked by [`check_domain`]) for user `uid`: `None`
/// for the default domain (the user's own `vpsom_u<uid>_`, see [`super::access`]), else
/// `vpsom<domain>-u<uid>_`. No prefix is the start of another (the default has `_` where a
/// domain's name starts, and `-` ends the domain's name), so listing one domain's files never
/// matches another's.
pub fn domain_prefix(domain: &str, uid: u32) -> Option<String> {
    (!domain.is_empty()).then(|| format!("vpsom{domain}-u{uid}_"))
}

/// A topic name: like a namespace, plus `/` between non-empty parts (e.g. `robot/state`).
pub(super) fn check_topic(s: &str) -> Result<(), &'static str> {
    if s.len() <= 96 && s.split('/').all(|part| check_namespace(part).is_ok()) {
        Ok(())
    } else {
        Err("must be 1..=96 characters of [A-Za-z0-9_-] parts joined by '/'")
    }
}
