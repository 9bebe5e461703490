//! The MSH reader on arbitrary bytes: it must return a mesh or an error, never panic, and a
//! mesh it returns must be written in its own format and read
//! back.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if data.len() > 64 * 1024 {
        return;
    }
    let Ok(mesh) = blossomquad::msh::read_bytes(data, "fuzz.msh") else {
        return;
    };
    let format = blossomquad::msh::default_output_format(&mesh);
    let mut out = Vec::new();
    // a write error (e.g. a mesh the format cannot hold) is an answer, not a finding
    if blossomquad::msh::write(&mesh, &mut out, format).is_ok() {
        // what the writer writes, the reader reads
        if let Err(e) = blossomquad::msh::read_bytes(&out, "rewritten.msh") {
            panic!("a mesh read from the input does not read back after writing: {e}");
        }
    }
});
