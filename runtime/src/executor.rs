//! Placeholder for the executor module.

use crate::config::{Checker, ConfigError};
use serde::Deserialize;

/// `[executor]` section.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ExecutorConfig {}

impl ExecutorConfig {
    /// Range-check.
    pub fn validate(&self, _c: &Checker) -> Result<(), ConfigError> {
        Ok(())
    }
}
