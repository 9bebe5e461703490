//! Step 9: the new nodes, then each surface's triangle blocks replaced by its quads.

use super::parity;
use super::surface::{SurfaceResult, SurfaceWork};
use crate::mesh::{etype, ElementBlock, Mesh, NodeTable};

/// Step 9: new nodes, then each surface's triangle blocks replaced by quads.
pub(super) fn write_back(
    mesh: &mut Mesh,
    nodes: &NodeTable,
    work: &[SurfaceWork],
    results: &[SurfaceResult],
) {
    let n_global = nodes.coords.len() as u32;
    let mut next_node = mesh.max_node_tag() + 1;
    for (w, r) in work.iter().zip(results) {
        let new_tags: Vec<u64> = r
            .faces
            .new_nodes
            .iter()
            .map(|nn| {
                let tag = next_node;
                next_node += 1;
                parity::add_node(mesh, nodes, 2, w.tag, tag, nn.pos, &nn.near, None);
                tag
            })
            .collect();
        let tag_of = |id: u32| -> u64 {
            if id < n_global {
                nodes.tags[id as usize]
            } else {
                new_tags[(id - n_global) as usize]
            }
        };
        let mut quad_nodes = Vec::with_capacity(4 * r.faces.quads.len());
        for q in &r.faces.quads {
            quad_nodes.extend(q.iter().map(|&i| tag_of(i)));
        }
        let quad_tags: Vec<u64> = r
            .faces
            .source
            .iter()
            .map(|&t| w.elem_tags[t as usize])
            .collect();
        let any_parts = w.partitions.iter().any(|p| p.is_some());
        let parts: Option<Vec<Vec<i32>>> = any_parts.then(|| {
            r.faces
                .source
                .iter()
                .map(|&t| w.partitions[t as usize].clone().unwrap_or_default())
                .collect()
        });
        let is_tri = |b: &ElementBlock| {
            b.element_type == etype::TRI3 && b.entity_dim == 2 && b.entity_tag == w.tag
        };
        let first_tri = mesh.element_blocks.iter().position(is_tri);
        let quad_block = mesh.element_blocks.iter().position(|b| {
            b.element_type == etype::QUAD4 && b.entity_dim == 2 && b.entity_tag == w.tag
        });
        match quad_block {
            Some(qb) => {
                let b = &mut mesh.element_blocks[qb];
                b.tags.extend_from_slice(&quad_tags);
                b.nodes.extend_from_slice(&quad_nodes);
                match (b.partitions.as_mut(), parts) {
                    (Some(p), Some(new)) => p.extend(new),
                    (Some(p), None) => p.extend(quad_tags.iter().map(|_| Vec::new())),
                    (None, Some(new)) => {
                        let mut all = vec![Vec::new(); b.tags.len() - new.len()];
                        all.extend(new);
                        b.partitions = Some(all);
                    }
                    (None, None) => {}
                }
                mesh.element_blocks.retain(|b| !is_tri(b));
            }
            None => {
                let block = ElementBlock {
                    entity_dim: 2,
                    entity_tag: w.tag,
                    element_type: etype::QUAD4,
                    tags: quad_tags,
                    nodes: quad_nodes,
                    partitions: parts,
                };
                let at = first_tri.unwrap_or(mesh.element_blocks.len());
                mesh.element_blocks.insert(at, block);
                mesh.element_blocks.retain(|b| !is_tri(b));
            }
        }
    }
}
