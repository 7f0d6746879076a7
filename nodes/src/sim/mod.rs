//! The simulated world, RGB-D camera, detector and robot (issue: sim node). Placeholder.

use runtime::config::{Checker, ConfigError};
use serde::Deserialize;

/// `[sim]` section.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SimConfig {}

impl SimConfig {
    /// Range-check.
    pub fn validate(&self, _c: &Checker) -> Result<(), ConfigError> {
        Ok(())
    }
}

/// `[detector]` section.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DetectorConfig {}

impl DetectorConfig {
    /// Range-check.
    pub fn validate(&self, _c: &Checker) -> Result<(), ConfigError> {
        Ok(())
    }
}

/// `[robot]` section.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RobotConfig {}

impl RobotConfig {
    /// Range-check.
    pub fn validate(&self, _c: &Checker) -> Result<(), ConfigError> {
        Ok(())
    }
}
