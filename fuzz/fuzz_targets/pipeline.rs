//! The whole pipeline on arbitrary bytes; the check is `fuzz/check/pipeline.rs` (its module
//! doc says what is asserted), shared with the ordinary test suite, which runs it over the
//! seed corpus and the recorded findings. Any finding is a panic.
#![no_main]

#[path = "../check/pipeline.rs"]
mod check;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Err(finding) = check::check(data) {
        panic!("{finding}");
    }
});
