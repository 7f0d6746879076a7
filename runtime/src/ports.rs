//! Placeholder for the ports module.

use crate::config::{Checker, ConfigError};
use serde::Deserialize;

/// `[ports]` section.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PortsConfig {}

impl PortsConfig {
    /// Range-check.
    pub fn validate(&self, _c: &Checker) -> Result<(), ConfigError> {
        Ok(())
    }
}
