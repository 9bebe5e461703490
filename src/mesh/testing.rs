//! Small meshes for the unit tests.

use super::{ElementBlock, Mesh, NodeBlock};

/// A node block on entity (`dim`, 1).
pub(crate) fn node_block(dim: i32, tags: Vec<u64>, coords: Vec<[f64; 3]>) -> NodeBlock {
    NodeBlock {
        entity_dim: dim,
        entity_tag: 1,
        tags,
        coords,
        params: None,
    }
}

/// The given node blocks and one element block on surface 1: `elems` (node tags each), all
/// of `element_type`, with element tags 1, 2, … in order.
pub(crate) fn one_surface(
    node_blocks: Vec<NodeBlock>,
    element_type: u32,
    elems: &[&[u64]],
) -> Mesh {
    let mut m = Mesh {
        node_blocks,
        ..Mesh::default()
    };
    m.element_blocks.push(ElementBlock {
        entity_dim: 2,
        entity_tag: 1,
        element_type,
        tags: (1..=elems.len() as u64).collect(),
        nodes: elems.iter().flat_map(|e| e.iter().copied()).collect(),
        partitions: None,
    });
    m
}
