//! The reader fuzz target's check, shared by `fuzz/fuzz_targets/read.rs` and the ordinary
//! test suite (`tests/e2e/fuzz_seeds.rs` runs it over the seed corpus): the MSH reader on
//! arbitrary bytes returns a mesh or an error, never panics, and a mesh it returns is
//! written in its own format and read back.

/// The check of one input: `Err` names the finding (a panic inside is one too).
pub fn check(data: &[u8]) -> Result<(), String> {
    if data.len() > 64 * 1024 {
        return Ok(());
    }
    let Ok(mesh) = blossomquad::msh::read_bytes(data, "fuzz.msh") else {
        return Ok(());
    };
    let format = blossomquad::msh::default_output_format(&mesh);
    let mut out = Vec::new();
    // a write error (e.g. a mesh the format cannot hold) is an answer, not a finding
    if blossomquad::msh::write(&mesh, &mut out, format).is_ok() {
        // what the writer writes, the reader reads
        if let Err(e) = blossomquad::msh::read_bytes(&out, "rewritten.msh") {
            return Err(format!(
                "a mesh read from the input does not read back after writing: {e}"
            ));
        }
    }
    Ok(())
}
