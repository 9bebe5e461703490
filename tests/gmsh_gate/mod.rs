//! Whether a test that needs Gmsh may run. CI installs Gmsh, so a missing `gmsh` is a
//! failure, not a skip: `require_gmsh()` panics with a clear message, unless
//! `BLOSSOMQUAD_ALLOW_NO_GMSH=1` is set, in which case it returns `false` and the caller
//! skips (loudly, on stderr).
#![allow(dead_code)]

use std::process::Command;

/// True when `gmsh --version` runs and succeeds.
pub fn gmsh_installed() -> bool {
    Command::new("gmsh")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// True when Gmsh is installed; false (skip) only with `BLOSSOMQUAD_ALLOW_NO_GMSH=1`;
/// panics otherwise.
pub fn require_gmsh() -> bool {
    if gmsh_installed() {
        return true;
    }
    if std::env::var("BLOSSOMQUAD_ALLOW_NO_GMSH").as_deref() == Ok("1") {
        eprintln!("gmsh not installed: SKIPPED because BLOSSOMQUAD_ALLOW_NO_GMSH=1");
        return false;
    }
    panic!(
        "gmsh is required by this test but `gmsh --version` failed: install it \
         (`python3 -m pip install gmsh==4.15.2`, or run scripts/test.sh) or set \
         BLOSSOMQUAD_ALLOW_NO_GMSH=1 to skip Gmsh tests"
    );
}
