//! Integration tests: optimize (one test binary; each module was a binary of its own).

#[path = "../common/mod.rs"]
mod common;

mod ops;
mod quality_report;
mod valid;
