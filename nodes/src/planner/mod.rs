//! Placeholder for the planner node.

use runtime::config::{Checker, ConfigError};
use serde::Deserialize;

/// `[planner]` section.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlannerConfig {}

impl PlannerConfig {
    /// Range-check.
    pub fn validate(&self, _c: &Checker) -> Result<(), ConfigError> {
        Ok(())
    }
}
