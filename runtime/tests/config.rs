//! `[executor]`, `[executor.pool]` and `[ports]`: the shipped defaults load (they are the structs'
//! defaults), a file merges over them; each bad value gives its specific error naming the key.

use runtime::config::{Checker, ConfigError, RUNTIME_DEFAULTS};
use runtime::executor::{ExecutorConfig, MissPolicy, SchedPolicy};
use runtime::ports::{Overflow, PortsConfig};
use serde::Deserialize;
use std::path::Path;

const SHIPPED: &str = include_str!("../../config/runtime.toml");

/// Only the sections owned by the runtime (other sections are ignored here).
#[derive(Debug, Deserialize)]
struct Root {
    executor: ExecutorConfig,
    ports: PortsConfig,
}

fn load(text: &str) -> Result<Root, ConfigError> {
    let file = Path::new("test.toml");
    let root: Root = RUNTIME_DEFAULTS.parse(file, text)?;
    let c = Checker::new(file);
    root.executor.validate(&c)?;
    root.ports.validate(&c)?;
    Ok(root)
}

#[test]
fn shipped_defaults_load() {
    let root = load(SHIPPED).unwrap();
    assert_eq!(root.executor, ExecutorConfig::default());
    assert_eq!(root.ports, PortsConfig::default());
    assert!(!root.ports.topics.is_empty());
    assert_eq!(root.ports.topic("sim/truth").subscriber_buffer, 256);
    assert_eq!(root.executor.policy, SchedPolicy::Fifo);
    assert_eq!(root.executor.miss_policy, MissPolicy::Skip);
    assert_eq!(root.ports.overflow, Overflow::Overwrite);
    // An empty file gives the same defaults.
    let empty = load("").unwrap();
    assert_eq!(empty.executor, ExecutorConfig::default());
}

#[test]
fn per_topic_overrides_merge_with_the_defaults() {
    let root = load("[ports]\nsubscriber_buffer = 3\n[ports.topics.lidar]\noverflow = \"block\"\n")
        .unwrap();
    let lidar = root.ports.topic("lidar");
    assert_eq!(lidar.overflow, Overflow::Block);
    assert_eq!(lidar.subscriber_buffer, 3);
    assert_eq!(root.ports.topic("map").overflow, Overflow::Overwrite);
    // A file's topic table merges with the shipped one of the same topic.
    let root = load("[ports.topics.depth]\noverflow = \"block\"\n").unwrap();
    let depth = root.ports.topic("depth");
    assert_eq!(depth.overflow, Overflow::Block);
    assert_eq!(depth.subscriber_buffer, 4);
}

fn range_key(text: &str) -> String {
    match load(text) {
        Err(e @ ConfigError::Range { .. }) => {
            assert!(e.to_string().starts_with("test.toml: "), "{e}");
            e.key().to_string()
        }
        other => panic!("expected a range error for {text:?}, got {other:?}"),
    }
}

#[test]
fn each_bad_value_gives_its_range_error() {
    let cases = [
        ("[executor]\npriority = 0\n", "executor.priority"),
        ("[executor]\npriority = 99\n", "executor.priority"),
        ("[executor]\nnice = 20\n", "executor.nice"),
        ("[executor]\ncpus = [0, 5000]\n", "executor.cpus"),
        (
            "[executor]\nspin_margin_us = 200000\n",
            "executor.spin_margin_us",
        ),
        (
            "[executor]\nbudget_fraction = 0.0\n",
            "executor.budget_fraction",
        ),
        (
            "[executor]\nbudget_fraction = 1.5\n",
            "executor.budget_fraction",
        ),
        (
            "[executor]\nbudget_fraction = nan\n",
            "executor.budget_fraction",
        ),
        (
            "[executor]\nescalate_after = 2000000\n",
            "executor.escalate_after",
        ),
        ("[executor.pool]\nqueue = 0\n", "executor.pool.queue"),
        ("[executor.pool]\nthreads = 1000\n", "executor.pool.threads"),
        ("[executor.pool]\nnice = -1\n", "executor.pool.nice"),
        ("[ports]\nnamespace = \"a/b\"\n", "ports.namespace"),
        ("[ports]\nnamespace = \"\"\n", "ports.namespace"),
        ("[ports]\nhistory_size = 65\n", "ports.history_size"),
        (
            "[ports]\nsubscriber_buffer = 0\n",
            "ports.subscriber_buffer",
        ),
        (
            "[ports]\nsubscriber_max_borrowed = 0\n",
            "ports.subscriber_max_borrowed",
        ),
        (
            "[ports]\npublisher_max_loaned = 0\n",
            "ports.publisher_max_loaned",
        ),
        ("[ports]\nmax_publishers = 0\n", "ports.max_publishers"),
        ("[ports]\nmax_subscribers = 100\n", "ports.max_subscribers"),
        ("[ports]\nmax_nodes = 1\n", "ports.max_nodes"),
        ("[ports]\nblock_timeout_ms = 0\n", "ports.block_timeout_ms"),
        (
            "[ports.topics.depth]\nsubscriber_buffer = 0\n",
            "ports.topics.depth.subscriber_buffer",
        ),
        ("[ports.topics.\"a b\"]\n", "ports.topics"),
    ];
    for (text, key) in cases {
        assert_eq!(range_key(text), key, "for {text:?}");
    }
    let e = load("[executor]\npriority = 0\n").unwrap_err();
    assert_eq!(
        e.to_string(),
        "test.toml: executor.priority = 0: must be in [1, 98]"
    );
}

#[test]
fn unknown_keys_and_bad_enum_values_are_parse_errors_naming_the_key() {
    let e = load("[executor]\npriorty = 3\n").unwrap_err();
    assert!(matches!(e, ConfigError::Parse { .. }), "{e}");
    assert_eq!(e.key(), "executor.priorty");
    let e = load("[executor]\nmiss_policy = \"explode\"\n").unwrap_err();
    assert_eq!(e.key(), "executor.miss_policy", "{e}");
    let e = load("[ports]\noverflow = \"sometimes\"\n").unwrap_err();
    assert_eq!(e.key(), "ports.overflow", "{e}");
    let e = load("[ports.topics.depth]\nnamespace = \"x\"\n").unwrap_err();
    assert!(e.to_string().contains("unknown field `namespace`"), "{e}");
    let e = load("[executor.pool]\npriority = \"high\"\n").unwrap_err();
    assert_eq!(e.key(), "executor.pool.priority", "{e}");
}
