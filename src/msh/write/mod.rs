//! Writers for MSH 4.1 ([`v4`]) and 2.2 ([`v2`]), ASCII and binary: what both share (the
//! output buffer, the header and the sections after the elements, the checks before
//! writing) is here.
//!
//! Floats are written with the shortest representation that reads back to the same bits
//! (`ryu`), integers with `itoa`; output goes through one buffer flushed every megabyte.

use std::io::{self, Write};

mod v2;
mod v4;

use super::error::{ErrorKind, MshError};
use crate::mesh::{Mesh, MshFormat, MshVersion, SectionPosition};

/// Buffered output with number formatting.
struct Out<'w> {
    w: &'w mut dyn Write,
    buf: Vec<u8>,
    binary: bool,
    ryu: ryu::Buffer,
    itoa: itoa::Buffer,
    /// Bytes handed to `w` so far, and the size expected (see [`expected_size`]).
    written: u64,
    expected: u64,
    progress: &'w mut dyn FnMut(u64, u64),
}

const FLUSH_AT: usize = 1 << 20;

impl<'w> Out<'w> {
    fn new(
        w: &'w mut dyn Write,
        binary: bool,
        expected: u64,
        progress: &'w mut dyn FnMut(u64, u64),
    ) -> Self {
        Out {
            w,
            buf: Vec::with_capacity(FLUSH_AT + 4096),
            binary,
            ryu: ryu::Buffer::new(),
            itoa: itoa::Buffer::new(),
            written: 0,
            expected,
            progress,
        }
    }
    #[inline]
    fn s(&mut self, s: &str) {
        self.buf.extend_from_slice(s.as_bytes());
    }
    #[inline]
    fn b(&mut self, s: &[u8]) {
        self.buf.extend_from_slice(s);
    }
    #[inline]
    fn int<I: itoa::Integer>(&mut self, v: I) {
        self.buf.extend_from_slice(self.itoa.format(v).as_bytes());
    }
    /// Integer followed by a space.
    #[inline]
    fn int_sp<I: itoa::Integer>(&mut self, v: I) {
        self.int(v);
        self.buf.push(b' ');
    }
    /// Shortest round-trip float, without a useless `.0`.
    #[inline]
    fn f(&mut self, v: f64) {
        let s = self.ryu.format(v);
        let s = s.strip_suffix(".0").unwrap_or(s);
        self.buf.extend_from_slice(s.as_bytes());
    }
    #[inline]
    fn nl(&mut self) {
        self.buf.push(b'\n');
    }
    #[inline]
    fn sp(&mut self) {
        self.buf.push(b' ');
    }
    #[inline]
    fn le_i32(&mut self, v: i32) {
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    #[inline]
    fn le_u64(&mut self, v: u64) {
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    #[inline]
    fn le_f64(&mut self, v: f64) {
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    /// A count: `size_t` in binary, ASCII text otherwise (no separator).
    fn count_u64(&mut self, v: u64) {
        if self.binary {
            self.le_u64(v)
        } else {
            self.int(v)
        }
    }
    #[inline]
    fn maybe_flush(&mut self) -> io::Result<()> {
        if self.buf.len() >= FLUSH_AT {
            self.w.write_all(&self.buf)?;
            self.written += self.buf.len() as u64;
            self.buf.clear();
            (self.progress)(self.written, self.expected.max(self.written));
        }
        Ok(())
    }
    fn finish(mut self) -> io::Result<()> {
        self.w.write_all(&self.buf)?;
        self.written += self.buf.len() as u64;
        self.buf.clear();
        self.w.flush()?;
        (self.progress)(self.written, self.written);
        Ok(())
    }
    fn section(&mut self, name: &str) {
        self.b(b"$");
        self.s(name);
        self.nl();
    }
    fn end(&mut self, name: &str) {
        self.b(b"$End");
        self.s(name);
        self.nl();
    }
}

/// True when data section `d` can be written into `format`: a section read from the file
/// in the same encoding (and for binary the same major version); a section the crate made
/// in the same encoding.
fn data_section_fits(mesh: &Mesh, d: &crate::mesh::DataSection, format: MshFormat) -> bool {
    match d.encoded_binary {
        Some(binary) => binary == format.binary,
        None => data_sections_fit(mesh, format),
    }
}

/// True when the mesh's `$NodeData`/`$ElementData` sections as read can be copied into
/// `format` (same encoding, and for binary the same major version).
fn data_sections_fit(mesh: &Mesh, format: MshFormat) -> bool {
    let src = mesh.format.unwrap_or(MshFormat {
        version: MshVersion::V41,
        binary: false,
    });
    if src.binary != format.binary {
        return false;
    }
    !format.binary
        || matches!(src.version, MshVersion::V2 { .. })
            == matches!(format.version, MshVersion::V2 { .. })
}

/// Number of nodes the writers emit (a block's tags without coordinates are skipped).
fn written_nodes(mesh: &Mesh) -> usize {
    mesh.node_blocks
        .iter()
        .map(|b| b.tags.len().min(b.coords.len()))
        .sum()
}

/// Number of elements the writers emit from block `b` (complete node lists only).
fn written_elements(b: &crate::mesh::ElementBlock) -> usize {
    b.tags
        .len()
        .min(b.nodes.len() / b.nodes_per_element().max(1))
}

/// True when MSH 2.2 output carries `$ParametricNodes`: ASCII, some parametric block, and
/// parametric values for every node on a curve or surface (the section has no way to say
/// "none" for a node, and zeros would be wrong data).
fn v22_parametric(mesh: &Mesh, format: MshFormat) -> bool {
    !format.binary
        && mesh.node_blocks.iter().any(|b| b.params.is_some())
        && mesh
            .node_blocks
            .iter()
            .filter(|b| b.entity_dim == 1 || b.entity_dim == 2)
            .all(|b| {
                b.params
                    .as_ref()
                    .is_some_and(|p| p.len() == b.tags.len() * b.entity_dim as usize)
            })
}

/// Warnings about what writing `mesh` as `format` will drop (data sections in another
/// encoding, parametric coordinates in binary MSH 2.2). Empty when nothing is lost.
pub fn write_warnings(mesh: &Mesh, format: MshFormat) -> Vec<String> {
    let mut w = Vec::new();
    let unfit = mesh
        .data_sections
        .iter()
        .filter(|d| !data_section_fits(mesh, d, format))
        .count();
    if unfit > 0 {
        w.push(format!(
            "dropped {unfit} $NodeData/$ElementData/$ElementNodeData section(s): they are encoded for another MSH variant"
        ));
    }
    let v2 = matches!(format.version, MshVersion::V2 { .. });
    if v2 && mesh.node_blocks.iter().any(|b| b.params.is_some()) && !v22_parametric(mesh, format) {
        w.push(
            "parametric node coordinates dropped: MSH 2.2 keeps them only in ASCII $ParametricNodes, with values for every curve and surface node".into(),
        );
    }
    for r in &mesh.raw_sections {
        if !raw_section_fits(mesh, &r.name, format) {
            w.push(format!(
                "${} dropped: its data is encoded for another MSH variant",
                r.name
            ));
        }
    }
    if mesh
        .element_blocks
        .iter()
        .any(|b| crate::mesh::element_node_count(b.element_type).is_none())
    {
        w.push("element blocks of unknown type skipped".into());
    }
    w
}

/// The mean width of a node's three ASCII coordinates with their separators, measured on
/// about a thousand nodes spread over the mesh (a planar mesh's z = 0 takes one character,
/// a typical x 18).
fn coordinates_width(mesh: &Mesh) -> u64 {
    let n: usize = mesh.node_blocks.iter().map(|b| b.coords.len()).sum();
    let step = (n / 1024).max(1);
    let mut ryu = ryu::Buffer::new();
    let (mut chars, mut count) = (0u64, 0u64);
    for c in mesh
        .node_blocks
        .iter()
        .flat_map(|b| b.coords.iter())
        .step_by(step)
    {
        for &x in c {
            let text = ryu.format(x);
            chars += text.strip_suffix(".0").unwrap_or(text).len() as u64 + 1;
            count += 1;
        }
    }
    if count == 0 {
        57
    } else {
        (3 * chars).div_ceil(count)
    }
}

/// About how many bytes writing `mesh` as `format` takes: the nodes and elements (which
/// make nearly all of a large file) counted per number, at the width of their largest tag
/// in ASCII and of coordinates as [`coordinates_width`] measures them; the data sections
/// and kept sections as read. For a progress bar only.
fn expected_size(mesh: &Mesh, format: MshFormat) -> u64 {
    let digits = |v: u64| u64::from(v.checked_ilog10().unwrap_or(0)) + 1;
    let max_node = mesh
        .node_blocks
        .iter()
        .flat_map(|b| b.tags.iter().copied())
        .max()
        .unwrap_or(0);
    let max_element = mesh
        .element_blocks
        .iter()
        .flat_map(|b| b.tags.iter().copied())
        .max()
        .unwrap_or(0);
    let (node_tag, element_tag, coords) = if format.binary {
        (8, 8, 24)
    } else {
        (
            digits(max_node) + 1,
            digits(max_element) + 1,
            coordinates_width(mesh),
        )
    };
    let nodes: u64 = mesh
        .node_blocks
        .iter()
        .map(|b| {
            let n = b.tags.len().min(b.coords.len()) as u64;
            let params = b.params.as_ref().map_or(0, |p| p.len() as u64);
            n * (node_tag + coords) + params * coords / 3
        })
        .sum();
    let elements: u64 = mesh
        .element_blocks
        .iter()
        .map(|b| {
            written_elements(b) as u64 * (element_tag + b.nodes_per_element() as u64 * node_tag)
        })
        .sum();
    let kept: u64 = mesh
        .data_sections
        .iter()
        .map(|d| d.body.len() as u64)
        .chain(mesh.raw_sections.iter().map(|r| r.body.len() as u64))
        .sum();
    nodes + elements + kept
}

/// Writes `mesh` to `w` in `format` (MSH 4.0 is written as 4.1). `name` is used in errors;
/// `progress(bytes written, bytes expected)` is called with 0 first, then about once a
/// megabyte, and at the end with both equal.
pub(crate) fn write_to(
    mesh: &Mesh,
    w: &mut dyn Write,
    format: MshFormat,
    name: &str,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<(), MshError> {
    let expected = expected_size(mesh, format);
    progress(0, expected.max(1));
    let mut out = Out::new(w, format.binary, expected, progress);
    let r = match format.version {
        MshVersion::V2 { .. } => v2::write_v22(mesh, &mut out, format),
        _ => v4::write_v41(mesh, &mut out, format),
    };
    r.and_then(|_| out.finish()).map_err(|e| {
        if let Some(inner) = e
            .get_ref()
            .and_then(|i| i.downcast_ref::<InvalidForFormat>())
        {
            MshError::new(name, ErrorKind::Invalid(inner.0.clone()))
        } else {
            MshError::io(name, "cannot write", e)
        }
    })
}

/// A mesh value the target format cannot express (carried through `io::Error`).
#[derive(Debug)]
struct InvalidForFormat(String);
impl std::fmt::Display for InvalidForFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}
impl std::error::Error for InvalidForFormat {}

fn invalid(msg: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidData, InvalidForFormat(msg))
}

fn head(out: &mut Out, mesh: &Mesh, version: &str) -> io::Result<()> {
    for r in mesh
        .raw_sections
        .iter()
        .filter(|r| r.position == SectionPosition::BeforeFormat)
    {
        out.section(&r.name);
        out.b(&r.body);
        out.end(&r.name);
    }
    out.section("MeshFormat");
    out.s(version);
    out.s(if out.binary { " 1 8\n" } else { " 0 8\n" });
    if out.binary {
        out.le_i32(1);
        out.nl();
    }
    out.end("MeshFormat");
    if !mesh.physical_names.is_empty() {
        out.section("PhysicalNames");
        out.int(mesh.physical_names.len());
        out.nl();
        for p in &mesh.physical_names {
            out.int_sp(p.dim);
            out.int_sp(p.tag);
            out.b(b"\"");
            out.s(&p.name.replace(['"', '\n', '\r'], "_"));
            out.b(b"\"\n");
        }
        out.end("PhysicalNames");
    }
    Ok(())
}

fn tail(out: &mut Out, mesh: &Mesh, format: MshFormat) -> io::Result<()> {
    for d in &mesh.data_sections {
        if !data_section_fits(mesh, d, format) {
            continue;
        }
        let n = d.kind.section_name();
        out.section(n);
        out.b(&d.body);
        out.end(n);
        out.maybe_flush()?;
    }
    for r in mesh.raw_sections.iter().filter(|r| {
        r.position == SectionPosition::AfterMesh && raw_section_fits(mesh, &r.name, format)
    }) {
        out.section(&r.name);
        out.b(&r.body);
        out.end(&r.name);
        out.maybe_flush()?;
    }
    Ok(())
}

/// Sections Gmsh itself interprets, whose encoding follows the file's (binary data in
/// binary files), and that exist in MSH 4 only.
const ENCODED_V4_SECTIONS: &[&str] = &["Parametrizations", "Edges", "Faces"];

/// True when kept section `name` can be written into `format`: unknown sections always
/// (Gmsh skips them), encoded 4.x sections only into 4.1 with the input's encoding.
fn raw_section_fits(mesh: &Mesh, name: &str, format: MshFormat) -> bool {
    if !ENCODED_V4_SECTIONS.contains(&name) {
        return true;
    }
    let src_binary = mesh.format.is_some_and(|f| f.binary);
    format.version == MshVersion::V41 && format.binary == src_binary
}

/// One ASCII `$Periodic` link: `dim tag masterTag`, the affine transform (4.1: `16 v…` or
/// `0`; 2.2: an `Affine v…` line when present), the node count and the node pairs.
fn periodic_link_ascii(out: &mut Out, l: &crate::mesh::PeriodicLink, v22: bool) {
    out.int_sp(l.dim);
    out.int_sp(l.tag);
    out.int(l.master_tag);
    out.nl();
    let aff: &[f64] = l.affine.as_deref().unwrap_or(&[]);
    if v22 {
        if aff.len() == 16 {
            out.s("Affine");
            for &x in aff {
                out.sp();
                out.f(x);
            }
            out.nl();
        }
    } else {
        out.int(aff.len());
        for &x in aff {
            out.sp();
            out.f(x);
        }
        out.nl();
    }
    out.int(l.node_pairs.len());
    out.nl();
    for &(a, m) in &l.node_pairs {
        out.int_sp(a);
        out.int(m);
        out.nl();
    }
}
