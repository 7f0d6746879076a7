//! Validation of received payloads: a consumer calls [`Validate::validate`] before trusting a
//! sample written by another process.

/// A payload field that is not finite or not in range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{message}.{field}: {reason}")]
pub struct ValidationError {
    /// The message type, e.g. `"DepthFrame"`.
    pub message: &'static str,
    /// The field path, e.g. `"objects[3].center"`.
    pub field: String,
    /// What is wrong with it, including the offending value.
    pub reason: String,
}

/// Checks a received payload for NaN/inf and out-of-range counts.
pub trait Validate {
    /// `Ok` if every float is finite and every count is within capacity.
    fn validate(&self) -> Result<(), ValidationError>;
}

pub(crate) struct Checker {
    pub message: &'static str,
}

impl Checker {
    pub fn finite(&self, field: &str, values: &[f32]) -> Result<(), ValidationError> {
        match values.iter().position(|v| !v.is_finite()) {
            None => Ok(()),
            Some(i) => Err(self.err(field, format!("element {i} is {} (not finite)", values[i]))),
        }
    }

    pub fn count(&self, field: &str, value: usize, max: usize) -> Result<(), ValidationError> {
        if value <= max {
            Ok(())
        } else {
            Err(self.err(field, format!("{value} exceeds capacity {max}")))
        }
    }

    pub fn range(&self, field: &str, value: f32, lo: f32, hi: f32) -> Result<(), ValidationError> {
        if value.is_finite() && value >= lo && value <= hi {
            Ok(())
        } else {
            Err(self.err(field, format!("{value} is outside [{lo}, {hi}]")))
        }
    }

    pub fn err(&self, field: &str, reason: String) -> ValidationError {
        ValidationError {
            message: self.message,
            field: field.to_string(),
            reason,
        }
    }
}
