//! Placeholder benchmark, replaced by the node's own.
fn main() {}
