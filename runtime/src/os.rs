//! The narrow module where runtime makes OS calls (scheduling, memory locking, affinity, clocks).
#![allow(unsafe_code)]
