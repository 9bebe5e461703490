//! Integration tests: recombine (one test binary; each module was a binary of its own).

#[path = "../corpus_gate/mod.rs"]
mod corpus_gate;
#[path = "../gmsh_gate/mod.rs"]
mod gmsh_gate;
#[path = "../recombine_util/mod.rs"]
mod recombine_util;

mod basic;
mod bench;
mod checker;
mod corpus;
mod extra;
mod fixtures;
mod gmsh;
mod optimal;
mod parity;
mod parity_property;
mod priced;
mod random;
mod strips;
