//! blossomquad: turns the triangle surface meshes Gmsh writes into all-quadrilateral meshes
//! with the Blossom-Quad method (Remacle et al. 2012): an exact minimum-cost perfect matching
//! on each surface's triangle-adjacency graph, then quad-specific optimization.
//!
//! Data flows `msh` (bytes → [`mesh::Mesh`]) → `recombine` (triangles → quads, using
//! `matching`) → optionally `refine` (uniform refinement) → `optimize` → `msh` (Mesh →
//! bytes). `quality` measures any mesh.
//! See ARCHITECTURE.md for the map and the invariants of each stage.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod matching;
pub mod mesh;
pub mod msh;
pub mod optimize;
pub mod pipeline;
pub mod quality;
pub mod recombine;
pub mod refine;
pub mod validity;

pub use pipeline::{quadrangulate, Error, Options, Progress, ProgressFn, Report, Stage};
