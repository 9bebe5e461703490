//! blossomquad: turns the triangle surface meshes Gmsh writes into all-quadrilateral meshes
//! with the Blossom-Quad method (Remacle et al. 2012): an exact minimum-cost perfect matching
//! on each surface's triangle-adjacency graph, then quad-specific optimization.
//!
//! Data flows `msh` (bytes → [`mesh::Mesh`]) → `recombine` (triangles → quads, using
//! `matching`) → optionally `refine` (uniform refinement) → `optimize` → `msh` (Mesh →
//! bytes). `quality` measures any mesh.
//! See ARCHITECTURE.md for the map and the invariants of each stage.
//!
//! ```no_run
//! # fn main() -> Result<(), blossomquad::Error> {
//! let mut mesh = blossomquad::read("part.msh")?;
//! let report = blossomquad::quadrangulate(&mut mesh, &blossomquad::Options::default())?;
//! println!("{} surfaces recombined", report.recombine.surfaces.len());
//! let format = blossomquad::msh::default_output_format(&mesh);
//! blossomquad::write(&mesh, "part-quads.msh", format)?;
//! # Ok(())
//! # }
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod arrays;
#[cfg(feature = "cli")]
pub mod cli;
pub mod high_order;
mod keysort;
pub mod matching;
mod memory;
pub mod mesh;
pub mod msh;
pub mod optimize;
pub mod pipeline;
pub mod profile;
mod progress;
pub mod quality;
pub mod recombine;
pub mod refine;
pub mod renumber;
mod reuse;
pub mod validity;
mod warning;

pub use mesh::{Mesh, MshFormat};

/// The crate's version (the Python package reports the same).
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
pub use pipeline::{
    quadrangulate, set_memory_release, Error, Options, Progress, ProgressFn, Report, Stage,
};
pub use warning::Warning;

/// Reads an MSH file (2.x or 4.x, ASCII or binary; `-` reads stdin).
pub fn read(path: impl AsRef<std::path::Path>) -> Result<Mesh, Error> {
    Ok(msh::read_file(path.as_ref())?)
}

/// Reads an MSH file held in memory; `name` stands for the file in error messages.
pub fn read_bytes(data: &[u8], name: &str) -> Result<Mesh, Error> {
    Ok(msh::read_bytes(data, name)?)
}

/// Writes `mesh` in `format` (atomically: a temporary file beside `path`, then renamed;
/// `-` writes stdout). [`msh::default_output_format`] gives the format it was read in.
pub fn write(
    mesh: &Mesh,
    path: impl AsRef<std::path::Path>,
    format: MshFormat,
) -> Result<(), Error> {
    Ok(msh::write_file(mesh, path.as_ref(), format)?)
}
