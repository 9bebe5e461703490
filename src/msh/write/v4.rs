//! The MSH 4.1 writer.

use std::io;

use super::{head, periodic_link_ascii, tail, written_elements, written_nodes, Out};
use crate::mesh::{Mesh, MshFormat};
use crate::msh::derive;

pub(super) fn write_v41(mesh: &Mesh, out: &mut Out, format: MshFormat) -> io::Result<()> {
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
