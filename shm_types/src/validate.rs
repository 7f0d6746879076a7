//! Validation of received payloads: a consumer calls [`Validate::validate`] before trusting a
//! sample written by another process.
//!
//! Validation allocates nothing while a payload is valid: a field is named by a [`Field`] (a
//! `&'static str`, or an array element and its field), and the error's strings are built only
//! when a check fails. It can therefore run on a real-time path.

use std::fmt;

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

/// Checks a received payload for NaN/inf, out-of-range counts and the type's documented rules
/// (listed on each message type's impl).
pub trait Validate {
    /// `Ok` if every float is finite, every count is within capacity and every rule holds.
    fn validate(&self) -> Result<(), ValidationError>;
}

/// The name of a checked field, formatted only when a check fails.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Field {
    /// A top-level field, e.g. `"width"`.
    Top(&'static str),
    /// Field `name` of element `index` of array `array`, e.g. `objects[3].center`.
    Item {
        array: &'static str,
        index: usize,
        name: &'static str,
    },
}

impl Field {
    /// Field `name` of element `index` of `array`.
    pub fn item(array: &'static str, index: usize, name: &'static str) -> Self {
        Field::Item { array, index, name }
    }
}

impl From<&'static str> for Field {
    fn from(name: &'static str) -> Self {
        Field::Top(name)
    }
}

impl fmt::Display for Field {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Field::Top(name) => f.write_str(name),
            Field::Item { array, index, name } => write!(f, "{array}[{index}].{name}"),
        }
    }
}

pub(crate) struct Checker {
    pub message: &'static str,
}

impl Checker {
    pub fn finite(&self, field: impl Into<Field>, values: &[f32]) -> Result<(), ValidationError> {
        match values.iter().position(|v| !v.is_finite()) {
            None => Ok(()),
            Some(i) => Err(self.err(field, format!("element {i} is {} (not finite)", values[i]))),
        }
    }

    pub fn count(
        &self,
        field: impl Into<Field>,
        value: usize,
        max: usize,
    ) -> Result<(), ValidationError> {
        if value <= max {
            Ok(())
        } else {
            Err(self.err(field, format!("{value} exceeds capacity {max}")))
        }
    }

    pub fn range(
        &self,
        field: impl Into<Field>,
        value: f32,
        lo: f32,
        hi: f32,
    ) -> Result<(), ValidationError> {
        if value.is_finite() && value >= lo && value <= hi {
            Ok(())
        } else {
            Err(self.err(field, format!("{value} is outside [{lo}, {hi}]")))
        }
    }

    /// Every element finite and within `[-limit, limit]`.
    pub fn within(
        &self,
        field: impl Into<Field>,
        values: &[f32],
        limit: f32,
    ) -> Result<(), ValidationError> {
        match values
            .iter()
            .position(|v| !(v.is_finite() && v.abs() <= limit))
        {
            None => Ok(()),
            Some(i) => Err(self.err(
                field,
                format!("element {i} is {}, outside [-{limit}, {limit}]", values[i]),
            )),
        }
    }

    /// A 0/1 flag.
    pub fn flag(&self, field: impl Into<Field>, value: u8) -> Result<(), ValidationError> {
        if value <= 1 {
            Ok(())
        } else {
            Err(self.err(field, format!("{value} (a flag is 0 or 1)")))
        }
    }

    /// A cluster id: -1 (none) or a (non-negative) background object id.
    pub fn cluster(&self, field: impl Into<Field>, value: i32) -> Result<(), ValidationError> {
        if value >= -1 {
            Ok(())
        } else {
            Err(self.err(
                field,
                format!("{value} (-1 for none, else an object id >= 0)"),
            ))
        }
    }

    pub fn err(&self, field: impl Into<Field>, reason: String) -> ValidationError {
        ValidationError {
            message: self.message,
            field: field.into().to_string(),
            reason,
        }
    }
}
