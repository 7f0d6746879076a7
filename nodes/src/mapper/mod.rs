//! Placeholder for the mapper node.

use runtime::config::{Checker, ConfigError};
use serde::Deserialize;

/// `[mapper]` section.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MapperConfig {}

impl MapperConfig {
    /// Range-check.
    pub fn validate(&self, _c: &Checker) -> Result<(), ConfigError> {
        Ok(())
    }
}
