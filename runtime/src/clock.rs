//! Placeholder for the clock module.
