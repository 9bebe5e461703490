//! Where the real MSH corpus is, for the tests over it: `$BLOSSOMQUAD_CORPUS`, else
//! `<crate>/../shared/corpus/real-msh` (CI has it). A clone with nothing beside it has no
//! corpus: those tests then return early, and the test binary prints one line saying so,
//! written straight to stderr so that `cargo test` shows it (the harness captures `println!`
//! of passing tests). Every quirk of the corpus also has an in-repository fixture
//! (`tests/data/quirks/`), so skipping these tests loses no quirk.
#![allow(dead_code)]

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Once;

/// The corpus folder, or `None` (after the one skip line of this test binary) when it does
/// not exist. A folder that exists but lacks files is not skipped: the tests fail on it.
pub fn corpus_dir() -> Option<PathBuf> {
    let dir = match std::env::var_os("BLOSSOMQUAD_CORPUS") {
        Some(dir) => PathBuf::from(dir),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/corpus/real-msh"),
    };
    if dir.is_dir() {
        return Some(dir);
    }
    static SAID: Once = Once::new();
    SAID.call_once(|| {
        // One write, so that tests running in parallel cannot split the line.
        let line = format!(
            "skipped: tests over the real MSH corpus (not at {}; set BLOSSOMQUAD_CORPUS to run them)\n",
            dir.display()
        );
        let _ = std::io::stderr().write_all(line.as_bytes());
    });
    None
}
