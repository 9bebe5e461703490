//! Reading and writing Gmsh MSH files (2.0/2.1/2.2 and 4.1, ASCII and binary; 4.0 ASCII
//! read only) into and from the [`Mesh`] model.
//!
//! Entry points: [`read_file`], [`read_bytes`], [`write()`], [`write_file`],
//! [`default_output_format`], [`summary()`].
//!
//! ```
//! use blossomquad::msh;
//! let text = b"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n2 1 0 0\n3 0 1 0\n$EndNodes\n$Elements\n1\n1 2 2 7 1 1 2 3\n$EndElements\n";
//! let mesh = msh::read_bytes(text, "tri.msh")?;
//! assert_eq!(mesh.entities[2][0].physical_tags, vec![7]);
//! let mut out = Vec::new();
//! msh::write(&mesh, &mut out, msh::default_output_format(&mesh))?; // MSH 2.2 ASCII
//! println!("{}", msh::summary(&mesh)); // format, entities, counts, parity, groups
//! # Ok::<(), msh::MshError>(())
//! ```
//!
//! Layout: `read` runs the section loop and dispatches to `v4` (4.1/4.0 sections) or `v2`
//! (2.x sections and the lift of flat 2.x lists into entities, rules below); `derive` computes bounding boxes and bounding entities that 2.x does not store;
//! `write` holds both writers; `scan` the allocation-free ASCII and binary cursors.
//!
//! # Writing
//!
//! MSH 2.2 output writes every element once per physical group of its entity (copies get
//! fresh ids above the largest element tag; an entity without group is written with
//! physical tag 0, so nothing is dropped), `$PhysicalNames` and `$Periodic` (ASCII) kept.
//! MSH 4.1 output writes every entity, including those derived from 2.x files (bounding
//! boxes from their nodes, bounding entities from lower-dimension elements on their
//! boundary, see `derive`). Unknown sections are written back (those read before
//! `$MeshFormat` first, the others after the mesh); data sections only when the target has
//! the same encoding ([`write_warnings`] says what a format drops).
//!
//! # Partitioned meshes
//!
//! `$PartitionedEntities` (4.1) is read into plain entities: every partition entity keeps
//! its physical groups and bounding entities, so the mesh is written back unpartitioned
//! (with a warning; `$GhostElements` are dropped). MSH 2.x partition tags are kept per
//! element ([`crate::mesh::ElementBlock::partitions`]) and written back in 2.2.
//!
//! # Reading MSH 2.x
//!
//! MSH 2.x has no `$Entities`; the reader lifts its flat lists into the model:
//! - Entities are derived from elementary tags; an element's entity dimension is its type's
//!   dimension. An element with fewer than two tags has elementary tag 0.
//! - Gmsh writes an element once per physical group of its entity. Copies (same entity,
//!   same type, same nodes, same partition tags, a physical tag not yet seen for that
//!   element) are merged into one element that keeps the first id; writing 2.2 writes it
//!   back once per physical group.
//! - Physical tags of an entity = the tags its elements carry (0 = no group). If elements of
//!   one elementary entity carry different physical sets (hand-written files), the entity is
//!   split: the first set keeps the tag, each other set gets a new entity (tag above the
//!   largest of that dimension) and a warning says so, so no element changes groups.
//! - A negative physical tag `-t` (reversed element in old Gmsh files) is read as group `t`,
//!   nodes kept as written, with a warning.
//! - Each node is classified on the lowest-dimension entity whose elements use it (ties: the
//!   smallest entity tag). A node no element uses gets its own new point entity. When
//!   `$ParametricNodes` is present, its classification and parametric values are used.
//! - Duplicate node tags are refused (references would be ambiguous); duplicate element
//!   tags are kept with a warning.
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
mod tags;
mod v2;
mod v4;
mod write;

use std::io::{Read, Write};
use std::path::Path;

pub(crate) use derive::{grow_box, EMPTY_BOX};
pub use error::{ErrorKind, Location, MshError};
pub use summary::{summary, GroupSummary, MeshSummary, SurfaceSummary};
pub use write::write_warnings;

use crate::mesh::{Mesh, MshFormat, MshVersion};

/// Reads an MSH file; `-` reads standard input.
///
/// Errors: [`ErrorKind::Io`] when the path cannot be read, otherwise any parse error of
/// [`read_bytes`].
pub fn read_file(path: &Path) -> Result<Mesh, MshError> {
    read_file_with_progress(path, &mut |_, _| {})
}

/// [`read_file`], calling `progress(bytes parsed, bytes in all)` as the parse goes: with 0
/// before the file is read, then at each section and every few ten thousand lines of an
/// ASCII node or element section; the last call has both equal.
pub fn read_file_with_progress(
    path: &Path,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<Mesh, MshError> {
    if path.as_os_str() == "-" {
        let mut data = Vec::new();
        std::io::stdin()
            .lock()
            .read_to_end(&mut data)
            .map_err(|e| MshError::io("<stdin>", "cannot read", e))?;
        return read::read_with_progress(&data, "<stdin>", progress);
    }
    let name = path.display().to_string();
    if let Ok(meta) = std::fs::metadata(path) {
        progress(0, meta.len());
    }
    let data = std::fs::read(path).map_err(|e| MshError::io(&name, "cannot read", e))?;
    read::read_with_progress(&data, &name, progress)
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
    write::write_to(mesh, w, format, "<output>", &mut |_, _| {})
}

/// Writes `mesh` to `path` atomically: a temporary file in the target's directory, renamed
/// over `path` only when complete, so no partial file is ever left. `-` writes standard
/// output.
///
/// The file gets the permissions of the file it replaces, or for a new file those any new
/// file gets (`0666` less the process's umask on Unix).
pub fn write_file(mesh: &Mesh, path: &Path, format: MshFormat) -> Result<(), MshError> {
    write_file_with_progress(mesh, path, format, &mut |_, _| {})
}

/// [`write_file`], calling `progress(bytes written, bytes expected)` as the output grows
/// (about once a megabyte). The expected size is an estimate made before writing: `done`
/// may pass it on ASCII output, and the last call has the final size as both.
pub fn write_file_with_progress(
    mesh: &Mesh,
    path: &Path,
    format: MshFormat,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<(), MshError> {
    if path.as_os_str() == "-" {
        let stdout = std::io::stdout();
        let mut lock = stdout.lock();
        return write::write_to(mesh, &mut lock, format, "<stdout>", progress);
    }
    let name = path.display().to_string();
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let mut builder = tempfile::Builder::new();
    builder.prefix(".blossomquad-").suffix(".msh.tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // the mode open(2) gives a new file, before the umask (tempfile's default is 0600)
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut tmp = builder.tempfile_in(dir).map_err(|e| {
        let action = if dir.is_dir() {
            "cannot create a file in its directory"
        } else {
            "its directory does not exist"
        };
        MshError::io(&name, action, without_temporary_name(e))
    })?;
    if let Ok(existing) = std::fs::metadata(path) {
        if existing.is_file() {
            tmp.as_file()
                .set_permissions(existing.permissions())
                .map_err(|e| MshError::io(&name, "cannot keep the permissions of", e))?;
        }
    }
    write::write_to(mesh, tmp.as_file_mut(), format, &name, progress)?;
    tmp.as_file()
        .sync_all()
        .map_err(|e| MshError::io(&name, "cannot write", e))?;
    tmp.persist(path)
        .map_err(|e| MshError::io(&name, "cannot replace", e.error))?;
    Ok(())
}

/// `e` without the temporary file's name, which tempfile appends (`... at path
/// DIR/.blossomquad-XXXX.msh.tmp`) and which means nothing to the user.
fn without_temporary_name(e: std::io::Error) -> std::io::Error {
    let text = e.to_string();
    match text.split_once(" at path ") {
        Some((message, _)) => std::io::Error::new(e.kind(), message.to_string()),
        None => e,
    }
}
