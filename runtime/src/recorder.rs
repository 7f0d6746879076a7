//! Placeholder for the recorder module.
