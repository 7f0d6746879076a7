//! Metrics, maps and plots of a session (placeholder).
