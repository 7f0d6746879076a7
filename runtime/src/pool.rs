//! Placeholder for the pool module.
