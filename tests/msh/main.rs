//! Integration tests: msh (one test binary; each module was a binary of its own).

#[path = "../gmsh_gate/mod.rs"]
mod gmsh_gate;
#[path = "../msh_common/mod.rs"]
mod msh_common;

mod corpus;
mod errors;
mod gmsh;
mod quirks;
