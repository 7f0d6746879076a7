//! [`NodeHealth`]: the liveness signal every node host publishes on the `health` topic a few
//! times a second from the thread that steps the node (so a node that hangs without dying stops
//! it), with what each of its input subscribers has received, dropped as invalid and lost to
//! overflow. The launcher restarts a node whose heartbeat stops and reports the counts in the
//! run summary.

use crate::Header;
use crate::validate::{Checker, Field, Validate, ValidationError};
#[cfg(feature = "ipc")]
use iceoryx2::prelude::ZeroCopySend;

/// Input topics per [`NodeHealth`] (the recorder has the most: about ten).
pub const MAX_HEALTH_INPUTS: usize = 16;
/// Bytes of a topic name in [`InputHealth`] (UTF-8, zero-padded).
pub const HEALTH_TOPIC_LEN: usize = 32;
/// Bytes of a node name in [`NodeHealth`] (UTF-8, zero-padded).
pub const HEALTH_NODE_LEN: usize = 16;

/// The account of one input subscriber of a node, since the node (process) started.
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Zeroable)]
#[repr(C)]
#[cfg_attr(feature = "ipc", derive(ZeroCopySend), type_name("vpsom::InputHealth"))]
pub struct InputHealth {
    /// Valid samples received.
    pub received: u64,
    /// Samples dropped on receipt because they failed validation.
    pub invalid: u64,
    /// Samples lost before they were read (sequence gaps: overwritten in a full buffer).
    pub overflow: u64,
    /// Topic name (e.g. `robot/state`), UTF-8, zero-padded.
    pub topic: [u8; HEALTH_TOPIC_LEN],
}

/// A node's heartbeat and input account.
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Zeroable)]
#[repr(C)]
#[cfg_attr(feature = "ipc", derive(ZeroCopySend), type_name("vpsom::NodeHealth"))]
pub struct NodeHealth {
    /// Header (`seq` counts this node process's heartbeats from 1).
    pub header: Header,
    /// Steps the node has completed since its process started.
    pub steps: u64,
    /// Process id of the node (a restarted node has a new one).
    pub pid: u32,
    /// Entries of `inputs` in use.
    pub count: u32,
    /// Node name (its role, e.g. `mapper`), UTF-8, zero-padded.
    pub node: [u8; HEALTH_NODE_LEN],
    /// One entry per input topic, `count` of them.
    pub inputs: [InputHealth; MAX_HEALTH_INPUTS],
}

/// A zero-padded name field as `&str` (`"?"` if it is not UTF-8).
fn name_of(bytes: &[u8]) -> &str {
    let end = bytes.iter().position(|b| *b == 0).unwrap_or(bytes.len());
    std::str::from_utf8(&bytes[..end]).unwrap_or("?")
}

/// Store `name` zero-padded (truncated at a char boundary).
fn set_name(out: &mut [u8], name: &str) {
    out.fill(0);
    let mut end = name.len().min(out.len());
    while !name.is_char_boundary(end) {
        end -= 1;
    }
    out[..end].copy_from_slice(&name.as_bytes()[..end]);
}

impl InputHealth {
    /// The topic name.
    pub fn topic_name(&self) -> &str {
        name_of(&self.topic)
    }
}

impl NodeHealth {
    /// The node name.
    pub fn node_name(&self) -> &str {
        name_of(&self.node)
    }

    /// Store the node name.
    pub fn set_node_name(&mut self, name: &str) {
        set_name(&mut self.node, name);
    }

    /// The inputs in use.
    pub fn inputs(&self) -> &[InputHealth] {
        &self.inputs[..(self.count as usize).min(MAX_HEALTH_INPUTS)]
    }

    /// Forget every input (before a host lists them again).
    pub fn clear_inputs(&mut self) {
        self.count = 0;
    }

    /// Append one input's account; ignored (returns `false`) when all
    /// [`MAX_HEALTH_INPUTS`] entries are taken.
    pub fn push_input(&mut self, topic: &str, received: u64, invalid: u64, overflow: u64) -> bool {
        let Some(e) = self.inputs.get_mut(self.count as usize) else {
            return false;
        };
        set_name(&mut e.topic, topic);
        (e.received, e.invalid, e.overflow) = (received, invalid, overflow);
        self.count += 1;
        true
    }
}

impl Validate for NodeHealth {
    fn validate(&self) -> Result<(), ValidationError> {
        let c = Checker {
            message: "NodeHealth",
        };
        c.count("count", self.count as usize, MAX_HEALTH_INPUTS)?;
        if std::str::from_utf8(&self.node).is_err() {
            return Err(c.err("node", "not UTF-8".into()));
        }
        for (k, e) in self.inputs().iter().enumerate() {
            if std::str::from_utf8(&e.topic).is_err() {
                return Err(c.err(Field::item("inputs", k, "topic"), "not UTF-8".into()));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::size_of;

    #[test]
    fn layout_is_pinned() {
        assert_eq!(size_of::<InputHealth>(), 24 + HEALTH_TOPIC_LEN);
        assert_eq!(
            size_of::<NodeHealth>(),
            24 + 8 + 4 + 4 + HEALTH_NODE_LEN + MAX_HEALTH_INPUTS * size_of::<InputHealth>()
        );
    }

    #[test]
    fn inputs_are_appended_up_to_capacity_and_names_read_back() {
        let mut h = NodeHealth::default();
        h.set_node_name("recorder");
        assert_eq!(h.node_name(), "recorder");
        for k in 0..MAX_HEALTH_INPUTS {
            assert!(h.push_input("robot/state", k as u64, 1, 2));
        }
        assert!(!h.push_input("one-too-many", 0, 0, 0));
        assert_eq!(h.inputs().len(), MAX_HEALTH_INPUTS);
        assert_eq!(h.inputs()[3].topic_name(), "robot/state");
        assert_eq!(h.inputs()[3].received, 3);
        assert!(h.validate().is_ok());
        h.clear_inputs();
        assert!(h.inputs().is_empty());
        // A 40-byte topic is cut at 32 bytes, on a char boundary.
        h.push_input(&"é".repeat(20), 0, 0, 0);
        assert_eq!(h.inputs()[0].topic_name(), "é".repeat(16));
    }

    #[test]
    fn bad_counts_and_names_are_rejected() {
        let mut h = NodeHealth {
            count: MAX_HEALTH_INPUTS as u32 + 1,
            ..NodeHealth::default()
        };
        let e = h.validate().unwrap_err();
        assert_eq!((e.field.as_str(), e.message), ("count", "NodeHealth"));
        h.count = 1;
        h.inputs[0].topic[0] = 0xff;
        assert_eq!(h.validate().unwrap_err().field, "inputs[0].topic");
    }
}
