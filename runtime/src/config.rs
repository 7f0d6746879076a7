//! Typed configuration loading: the `settings` crate's loaders and range checks, re-exported for
//! the runtime's own sections (`[executor]`, `[ports]`, `[recorder]`).

pub use settings::*;
