//! The MSH 2.2 writer.

use std::collections::HashMap;
use std::io;

use super::{
    head, invalid, periodic_link_ascii, tail, v22_parametric, written_elements, written_nodes, Out,
};
use crate::mesh::{Entity, Mesh, MshFormat};

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

pub(super) fn write_v22(mesh: &Mesh, out: &mut Out, format: MshFormat) -> io::Result<()> {
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
