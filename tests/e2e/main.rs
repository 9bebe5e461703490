//! Integration tests: e2e (one test binary; each module was a binary of its own).

#[path = "../common/mod.rs"]
mod common;
#[path = "../gmsh_gate/mod.rs"]
mod gmsh_gate;

mod checker;
mod cli;
mod convert;
mod corpus;
mod fixtures;
mod footprint;
mod fuzz_regressions;
mod fuzz_seeds;
mod numbering;
mod parity_periodic;
mod quirks;
mod recombine;
mod refine;
mod robust;
mod second_order;
mod user_quads;
mod validity;
