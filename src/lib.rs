//! blossomquad: turns the triangle surface meshes Gmsh writes into all-quadrilateral meshes
//! with the Blossom-Quad method (Remacle et al. 2012): an exact minimum-cost perfect matching
//! on each surface's triangle-adjacency graph, then quad-specific optimization.
//!
//! Data flows [`msh`] (bytes → [`Mesh`]) → [`quadrangulate`] (recombination with the
//! [`matching`] solver, optional refinement, optimization, checks) → [`msh`] (Mesh → bytes).
//! [`quality`] measures any mesh.
//!
//! # The public API
//! - The crate root: [`read`], [`read_bytes`], [`write()`] (in an [`MshFormat`]),
//!   [`quadrangulate`] with its [`Options`], [`Report`] and [`Error`]; the progress types
//!   ([`Progress`], [`ProgressFn`], [`Stage`]), the developer hook [`Trace`]
//!   ([`TraceEvent`]), [`Warning`], [`set_memory_release`] and [`VERSION`].
//! - [`mesh`]: the model ([`Mesh`], its blocks and entities, element types); [`msh`]: MSH
//!   files and bytes ⇄ [`Mesh`], with their errors.
//! - [`report`]: the stage reports inside a [`Report`] and the stage errors inside an
//!   [`Error`].
//! - [`quality`]: quality reports (η, scaled Jacobian, vertex degrees, τ) and views.
//! - [`matching`]: the minimum-cost perfect matching ([`matching::solve`]) and its
//!   certificate ([`matching::verify`]).
//! - [`arrays`]: one surface given as point and triangle arrays; `cli` (feature `cli`, on
//!   by default): the command line (`main`, `run_args`).
//!
//! The stages themselves are private to the crate. The feature `testing` makes them public
//! for the project's own tests, examples and fuzz targets; it is not a stable API.
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
// every type in a public signature is public too (reachable by its path)
#![warn(unnameable_types)]

/// Declares the crate's internal modules: public with the `testing` feature (for the
/// project's own integration tests, examples and fuzz targets; not a stable API), private to
/// the crate otherwise.
macro_rules! internal {
    ($($(#[$attr:meta])* mod $name:ident;)*) => {
        $(
            $(#[$attr])*
            #[cfg(feature = "testing")]
            pub mod $name;
            $(#[$attr])*
            #[cfg(not(feature = "testing"))]
            pub(crate) mod $name;
        )*
    };
}

pub mod arrays;
#[cfg(feature = "cli")]
pub mod cli;
pub mod matching;
pub mod mesh;
pub mod msh;
pub mod quality;
pub mod report;

internal! {
    mod high_order;
    mod optimize;
    mod pipeline;
    mod profile;
    mod recombine;
    mod refine;
    mod renumber;
    mod validity;
}

mod keysort;
#[cfg(test)]
mod layers;
mod memory;
mod par;
mod progress;
mod reuse;
mod warning;

pub use mesh::{Mesh, MshFormat};

/// The crate's version (the Python package reports the same).
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
pub use pipeline::{
    quadrangulate, set_memory_release, Error, Options, Progress, ProgressFn, Report, Stage,
};
pub use profile::{Trace, TraceEvent};
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
