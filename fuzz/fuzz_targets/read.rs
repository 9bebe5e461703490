//! The MSH reader on arbitrary bytes; the check is `fuzz/check/read.rs`, shared with the
//! ordinary test suite, which runs it over the seed corpus. Any finding is a panic.
#![no_main]

#[path = "../check/read.rs"]
mod check;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Err(finding) = check::check(data) {
        panic!("{finding}");
    }
});
