//! Placeholder for the doctor module.
