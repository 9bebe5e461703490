//! Reading and writing Gmsh MSH files (2.0/2.1/2.2 and 4.1, ASCII and binary; 4.0 ASCII
//! read only) into and from the [`Mesh`] model.
//!
//! Entry points: [`read_file`], [`read_bytes`], [`write`], [`write_file`],
//! [`default_output_format`], [`summary`].
//!
//! Layout: `read` runs the section loop and dispatches to `v4` (4.1/4.0 sections) or `v2`
//! (2.x sections and the lift of flat 2.x lists into entities, see that module for the
//! rules); `derive` computes bounding boxes and bounding entities that 2.x does not store;
//! `write` holds both writers; `scan` the allocation-free ASCII and binary cursors.
//!
//! **Invariant:** reading never panics: every failure is an [`MshError`] naming the file, the
//! section, and the line (ASCII) or byte offset (binary).
//!
//! **Invariant:** a 4.1 → 4.1 copy reproduces node coordinates bit for bit (floats are
//! written with the shortest round-trip representation).

mod derive;
mod error;
mod read;
mod scan;
mod summary;
mod v2;
mod v4;
mod write;

use std::io::{Read, Write};
use std::path::Path;

pub use error::{ErrorKind, Location, MshError};
pub use summary::{summary, GroupSummary, MeshSummary, SurfaceSummary};
pub use write::write_warnings;

use crate::mesh::{Mesh, MshFormat, MshVersion};

/// Reads an MSH file; `-` reads standard input.
///
/// Errors: [`ErrorKind::Io`] when the path cannot be read, otherwise any parse error of
/// [`read_bytes`].
pub fn read_file(path: &Path) -> Result<Mesh, MshError> {
    if path.as_os_str() == "-" {
        let mut data = Vec::new();
        std::io::stdin()
            .lock()
            .read_to_end(&mut data)
            .map_err(|e| MshError::io("<stdin>", "cannot read", e))?;
        return read_bytes(&data, "<stdin>");
    }
    let name = path.display().to_string();
    let data = std::fs::read(path).map_err(|e| MshError::io(&name, "cannot read", e))?;
    read_bytes(&data, &name)
}

/// Parses an MSH file held in memory. `source` names the input in error messages.
pub fn read_bytes(data: &[u8], source: &str) -> Result<Mesh, MshError> {
    read::read(data, source)
}

/// The format a mesh is written in by default: the input's version and encoding, with
/// 4.0 → 4.1 and 2.0/2.1 → 2.2 (meshes built in memory: 4.1 ASCII).
pub fn default_output_format(mesh: &Mesh) -> MshFormat {
    match mesh.format {
        Some(f) => MshFormat {
            version: match f.version {
                MshVersion::V2 { .. } => MshVersion::V2 { minor: 2 },
                _ => MshVersion::V41,
            },
            binary: f.binary,
        },
        None => MshFormat {
            version: MshVersion::V41,
            binary: false,
        },
    }
}

/// Writes `mesh` to `w` as MSH `format` (2.x versions are written as 2.2, 4.x as 4.1).
///
/// Data sections that do not fit the target encoding are skipped; [`write_warnings`] lists
/// what a given format loses.
pub fn write(mesh: &Mesh, w: &mut impl Write, format: MshFormat) -> Result<(), MshError> {
    write::write_to(mesh, w, format, "<output>")
}

/// Writes `mesh` to `path` atomically: a temporary file in the target's directory, renamed
/// over `path` only when complete, so no partial file is ever left. `-` writes standard
/// output.
pub fn write_file(mesh: &Mesh, path: &Path, format: MshFormat) -> Result<(), MshError> {
    if path.as_os_str() == "-" {
        let stdout = std::io::stdout();
        let mut lock = stdout.lock();
        return write::write_to(mesh, &mut lock, format, "<stdout>");
    }
    let name = path.display().to_string();
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let mut tmp = tempfile::Builder::new()
        .prefix(".blossomquad-")
        .suffix(".msh.tmp")
        .tempfile_in(dir)
        .map_err(|e| MshError::io(&name, "cannot create a temporary file next to", e))?;
    write::write_to(mesh, tmp.as_file_mut(), format, &name)?;
    tmp.as_file()
        .sync_all()
        .map_err(|e| MshError::io(&name, "cannot write", e))?;
    tmp.persist(path)
        .map_err(|e| MshError::io(&name, "cannot rename the temporary file to", e.error))?;
    Ok(())
}
