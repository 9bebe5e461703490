//! Writers for MSH 4.1 and 2.2, ASCII and binary.
//!
//! Floats are written with the shortest representation that reads back to the same bits
//! (`ryu`), integers with `itoa`; output goes through one buffer flushed every megabyte.

use std::collections::HashMap;
use std::io::{self, Write};

use super::derive;
use super::error::{ErrorKind, MshError};
use crate::mesh::{Entity, Mesh, MshFormat, MshVersion, SectionPosition};

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
        MshVersion::V2 { .. } => write_v22(mesh, &mut out, format),
        _ => write_v41(mesh, &mut out, format),
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

fn write_v41(mesh: &Mesh, out: &mut Out, format: MshFormat) -> io::Result<()> {
    let bin = format.binary;
    head(out, mesh, "4.1")?;

    // $Entities
    // Gmsh refuses blocks on entities it does not know: complete the list when needed.
    let completed;
    let ents = if derive::find_missing_entities(mesh).is_empty() {
        &mesh.entities
    } else {
        let mut m = mesh.clone();
        derive::missing_entities(&mut m);
        completed = m.entities;
        &completed
    };
    out.section("Entities");
    for (d, v) in ents.iter().enumerate() {
        out.count_u64(v.len() as u64);
        if !bin {
            out.b(if d < 3 { b" " } else { b"\n" });
        }
    }
    for (d, v) in ents.iter().enumerate() {
        for e in v {
            let nbox = if d == 0 { 3 } else { 6 };
            if bin {
                out.le_i32(e.tag);
                for &x in &e.bbox[..nbox] {
                    out.le_f64(x);
                }
                out.le_u64(e.physical_tags.len() as u64);
                for &p in &e.physical_tags {
                    out.le_i32(p);
                }
                if d > 0 {
                    out.le_u64(e.bounding.len() as u64);
                    for &b in &e.bounding {
                        out.le_i32(b);
                    }
                }
            } else {
                out.int_sp(e.tag);
                for &x in &e.bbox[..nbox] {
                    out.f(x);
                    out.sp();
                }
                out.int_sp(e.physical_tags.len());
                for &p in &e.physical_tags {
                    out.int_sp(p);
                }
                if d > 0 {
                    out.int_sp(e.bounding.len());
                    for &b in &e.bounding {
                        out.int_sp(b);
                    }
                }
                out.nl();
            }
            out.maybe_flush()?;
        }
    }
    if bin {
        out.nl();
    }
    out.end("Entities");

    // $Nodes
    out.section("Nodes");
    let nn = written_nodes(mesh);
    let (lo, hi) = tag_range(mesh.node_blocks.iter().flat_map(|b| &b.tags));
    header4(out, mesh.node_blocks.len() as u64, nn as u64, lo, hi);
    for b in &mesh.node_blocks {
        let n = b.tags.len().min(b.coords.len());
        let np = b.entity_dim.clamp(0, 3) as usize;
        let params = b.params.as_ref().filter(|p| p.len() == n * np);
        let parametric = params.is_some();
        if bin {
            out.le_i32(b.entity_dim);
            out.le_i32(b.entity_tag);
            out.le_i32(parametric as i32);
            out.le_u64(n as u64);
            for &t in &b.tags[..n] {
                out.le_u64(t);
            }
            for (i, c) in b.coords[..n].iter().enumerate() {
                for &x in c {
                    out.le_f64(x);
                }
                if let Some(p) = params {
                    for &x in &p[i * np..(i + 1) * np] {
                        out.le_f64(x);
                    }
                }
                out.maybe_flush()?;
            }
        } else {
            out.int_sp(b.entity_dim);
            out.int_sp(b.entity_tag);
            out.int_sp(parametric as i32);
            out.int(n);
            out.nl();
            for &t in &b.tags[..n] {
                out.int(t);
                out.nl();
                out.maybe_flush()?;
            }
            for (i, c) in b.coords[..n].iter().enumerate() {
                out.f(c[0]);
                out.sp();
                out.f(c[1]);
                out.sp();
                out.f(c[2]);
                if let Some(p) = params {
                    for &x in &p[i * np..(i + 1) * np] {
                        out.sp();
                        out.f(x);
                    }
                }
                out.nl();
                out.maybe_flush()?;
            }
        }
    }
    if bin {
        out.nl();
    }
    out.end("Nodes");

    // $Elements
    out.section("Elements");
    let blocks: Vec<_> = mesh
        .element_blocks
        .iter()
        .filter(|b| b.nodes_per_element() > 0)
        .collect();
    let ne: usize = blocks.iter().map(|b| written_elements(b)).sum();
    let (lo, hi) = tag_range(blocks.iter().flat_map(|b| &b.tags));
    header4(out, blocks.len() as u64, ne as u64, lo, hi);
    for b in &blocks {
        let k = b.nodes_per_element();
        let n = written_elements(b);
        if bin {
            out.le_i32(b.entity_dim);
            out.le_i32(b.entity_tag);
            out.le_i32(b.element_type as i32);
            out.le_u64(n as u64);
        } else {
            out.int_sp(b.entity_dim);
            out.int_sp(b.entity_tag);
            out.int_sp(b.element_type);
            out.int(n);
            out.nl();
        }
        for (i, el) in b.nodes.chunks_exact(k).take(n).enumerate() {
            if bin {
                out.le_u64(b.tags[i]);
                for &v in el {
                    out.le_u64(v);
                }
            } else {
                out.int(b.tags[i]);
                for &v in el {
                    out.sp();
                    out.int(v);
                }
                out.nl();
            }
            out.maybe_flush()?;
        }
    }
    if bin {
        out.nl();
    }
    out.end("Elements");

    // $Periodic
    if !mesh.periodic.is_empty() {
        out.section("Periodic");
        out.count_u64(mesh.periodic.len() as u64);
        if !bin {
            out.nl();
        }
        for l in &mesh.periodic {
            let aff: &[f64] = l.affine.as_deref().unwrap_or(&[]);
            if bin {
                out.le_i32(l.dim);
                out.le_i32(l.tag);
                out.le_i32(l.master_tag);
                out.le_u64(aff.len() as u64);
                for &x in aff {
                    out.le_f64(x);
                }
                out.le_u64(l.node_pairs.len() as u64);
                for &(a, m) in &l.node_pairs {
                    out.le_u64(a);
                    out.le_u64(m);
                }
            } else {
                periodic_link_ascii(out, l, false);
            }
            out.maybe_flush()?;
        }
        if bin {
            out.nl();
        }
        out.end("Periodic");
    }
    tail(out, mesh, format)
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

/// Smallest and largest tag (`(0, 0)` when there is none).
fn tag_range<'a>(tags: impl Iterator<Item = &'a u64>) -> (u64, u64) {
    tags.fold(None, |acc: Option<(u64, u64)>, &t| {
        Some(acc.map_or((t, t), |(lo, hi)| (lo.min(t), hi.max(t))))
    })
    .unwrap_or((0, 0))
}

/// `numBlocks numItems minTag maxTag`.
fn header4(out: &mut Out, blocks: u64, n: u64, lo: u64, hi: u64) {
    if out.binary {
        for v in [blocks, n, lo, hi] {
            out.le_u64(v);
        }
    } else {
        out.int_sp(blocks);
        out.int_sp(n);
        out.int_sp(lo);
        out.int(hi);
        out.nl();
    }
}

fn to_i32(v: u64, what: &str) -> io::Result<i32> {
    i32::try_from(v).map_err(|_| {
        invalid(format!(
            "{what} {v} does not fit the 32-bit ints of binary MSH 2.2"
        ))
    })
}

/// The order MSH 2.2 writes the nodes in, as (block, index): ascending by tag, as Gmsh
/// writes its flat `$Nodes` list (meshio's binary 2.2 reader requires the tags 1..N in that
/// order); block after block when they are so already, and among equal tags in block order.
fn v22_node_order(mesh: &Mesh) -> Box<dyn Iterator<Item = (usize, usize)> + '_> {
    let written = |(bi, b): (usize, &'_ crate::mesh::NodeBlock)| {
        (0..b.tags.len().min(b.coords.len())).map(move |i| (bi, i))
    };
    let in_order = mesh
        .node_blocks
        .iter()
        .enumerate()
        .flat_map(written)
        .map(|(bi, i)| mesh.node_blocks[bi].tags[i])
        .try_fold(0u64, |last, t| (t >= last).then_some(t))
        .is_some();
    if in_order {
        return Box::new(mesh.node_blocks.iter().enumerate().flat_map(written));
    }
    let mut order: Vec<(u64, usize, usize)> = mesh
        .node_blocks
        .iter()
        .enumerate()
        .flat_map(written)
        .map(|(bi, i)| (mesh.node_blocks[bi].tags[i], bi, i))
        .collect();
    order.sort_by_key(|&(t, _, _)| t);
    Box::new(order.into_iter().map(|(_, bi, i)| (bi, i)))
}

fn write_v22(mesh: &Mesh, out: &mut Out, format: MshFormat) -> io::Result<()> {
    let bin = format.binary;
    head(out, mesh, "2.2")?;

    // $Nodes / $ParametricNodes
    let parametric = v22_parametric(mesh, format);
    let nn = written_nodes(mesh);
    let name = if parametric {
        "ParametricNodes"
    } else {
        "Nodes"
    };
    out.section(name);
    out.int(nn);
    out.nl();
    for (bi, i) in v22_node_order(mesh) {
        let b = &mesh.node_blocks[bi];
        let np = if b.entity_dim == 1 || b.entity_dim == 2 {
            b.entity_dim as usize
        } else {
            0
        };
        let n = b.tags.len().min(b.coords.len());
        let params = b.params.as_ref().filter(|p| p.len() == n * np && np > 0);
        {
            let (t, c) = (b.tags[i], &b.coords[i]);
            if bin {
                out.le_i32(to_i32(t, "node tag")?);
                for &x in c {
                    out.le_f64(x);
                }
            } else {
                out.int_sp(t);
                out.f(c[0]);
                out.sp();
                out.f(c[1]);
                out.sp();
                out.f(c[2]);
                if parametric {
                    out.sp();
                    out.int_sp(b.entity_dim);
                    out.int(b.entity_tag);
                    for j in 0..np {
                        out.sp();
                        out.f(params.map_or(0.0, |p| p[i * np + j]));
                    }
                }
                out.nl();
            }
            out.maybe_flush()?;
        }
    }
    if bin {
        out.nl();
    }
    out.end(name);

    // $Elements: once per physical group of the element's entity (tag 0 when none).
    let ents: HashMap<(i32, i32), &Entity> = mesh
        .entities
        .iter()
        .flatten()
        .map(|e| ((e.dim, e.tag), e))
        .collect();
    let none = [0i32];
    let phys_of = |d: i32, t: i32| -> &[i32] {
        match ents.get(&(d, t)) {
            Some(e) if !e.physical_tags.is_empty() => &e.physical_tags,
            _ => &none,
        }
    };
    let blocks: Vec<_> = mesh
        .element_blocks
        .iter()
        .filter(|b| b.nodes_per_element() > 0)
        .collect();
    let total: usize = blocks
        .iter()
        .map(|b| written_elements(b) * phys_of(b.entity_dim, b.entity_tag).len())
        .sum();
    out.section("Elements");
    out.int(total);
    out.nl();
    let mut next_id = mesh.max_element_tag();
    for b in &blocks {
        let k = b.nodes_per_element();
        let phys = phys_of(b.entity_dim, b.entity_tag);
        let n = written_elements(b);
        let parts = |i: usize| -> &[i32] {
            b.partitions
                .as_ref()
                .and_then(|p| p.get(i))
                .map_or(&[][..], |v| v.as_slice())
        };
        // Binary: runs of elements with the same tag count share one block header.
        let mut i = 0;
        while i < n {
            let ntags = 2 + parts(i).len();
            let mut j = i + 1;
            while j < n && 2 + parts(j).len() == ntags {
                j += 1;
            }
            if bin {
                out.le_i32(b.element_type as i32);
                out.le_i32(to_i32(((j - i) * phys.len()) as u64, "element count")?);
                out.le_i32(ntags as i32);
            }
            for e in i..j {
                let el = &b.nodes[e * k..(e + 1) * k];
                for (c, &p) in phys.iter().enumerate() {
                    let id = if c == 0 {
                        b.tags[e]
                    } else {
                        next_id += 1;
                        next_id
                    };
                    if bin {
                        out.le_i32(to_i32(id, "element id")?);
                        out.le_i32(p);
                        out.le_i32(b.entity_tag);
                        for &q in parts(e) {
                            out.le_i32(q);
                        }
                        for &v in el {
                            out.le_i32(to_i32(v, "node tag")?);
                        }
                    } else {
                        out.int_sp(id);
                        out.int_sp(b.element_type);
                        out.int_sp(ntags);
                        out.int_sp(p);
                        out.int(b.entity_tag);
                        for &q in parts(e) {
                            out.sp();
                            out.int(q);
                        }
                        for &v in el {
                            out.sp();
                            out.int(v);
                        }
                        out.nl();
                    }
                }
                out.maybe_flush()?;
            }
            i = j;
        }
    }
    if bin {
        out.nl();
    }
    out.end("Elements");

    // $Periodic (ASCII in every 2.2 variant).
    if !mesh.periodic.is_empty() {
        out.section("Periodic");
        out.int(mesh.periodic.len());
        out.nl();
        for l in &mesh.periodic {
            periodic_link_ascii(out, l, true);
            out.maybe_flush()?;
        }
        out.end("Periodic");
    }
    tail(out, mesh, format)
}
