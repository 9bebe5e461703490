//! Integration tests: matching (one test binary; each module was a binary of its own).

#[path = "../matching_common/mod.rs"]
mod matching_common;

mod brute;
mod families;
