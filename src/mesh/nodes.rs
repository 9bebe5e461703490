//! Node lookups by tag: the one block-order numbering of a mesh's nodes and the views over it.
//!
//! - [`NodeIndex`]: tag → [`NodeRef`] (block, index inside the block), dense when tags are
//!   compact, hashed otherwise. The public lookup; the readers and `refine` use it alone.
//! - [`NodeTable`]: the crate's one numbering of nodes, block after block (a node's *id* is
//!   its block's start plus its index in the block), with coordinates, tags and blocks per id
//!   and a [`NodeIndex`] for tag → id. `quality`, `optimize`, `recombine` and `high_order`
//!   all number nodes this way, so ids agree between them.
//! - [`TagCoords`]: coordinates straight by tag, for the checks that visit every element in
//!   file order (validity, the recombination invariants, the input checks).
//!
//! All three follow the same two rules: tags are dense (a table indexed by tag) when the
//! largest tag is at most `max(4 × node count, 1024)`, else hashed; a tag given twice names
//! its last occurrence in block order.

use std::collections::HashMap;

use glam::DVec3;

use super::Mesh;

/// Length of a table indexed by node tag, when `mesh`'s tags are compact enough for one.
fn dense_len(mesh: &Mesh) -> Option<usize> {
    let max = mesh.max_node_tag();
    (max <= (4 * mesh.node_count() as u64).max(1024)).then_some(max as usize + 1)
}

/// Position of a node in the model: block index and index inside the block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NodeRef {
    /// Index into [`Mesh::node_blocks`].
    pub block: u32,
    /// Index inside the block.
    pub index: u32,
}

/// Lookup from node tag to its position, dense when tags are compact, hashed otherwise.
#[derive(Debug, Clone)]
pub struct NodeIndex {
    dense: Vec<Option<NodeRef>>,
    sparse: HashMap<u64, NodeRef>,
}

impl NodeIndex {
    /// Builds the index for all nodes of `mesh`. Later duplicates of a tag win.
    pub fn new(mesh: &Mesh) -> Self {
        let dense_len = dense_len(mesh);
        let mut dense = Vec::new();
        let mut sparse = HashMap::new();
        if let Some(len) = dense_len {
            dense = vec![None; len];
        }
        for (bi, b) in mesh.node_blocks.iter().enumerate() {
            for (i, &t) in b.tags.iter().enumerate() {
                let r = NodeRef {
                    block: bi as u32,
                    index: i as u32,
                };
                if dense_len.is_some() {
                    dense[t as usize] = Some(r);
                } else {
                    sparse.insert(t, r);
                }
            }
        }
        NodeIndex { dense, sparse }
    }

    /// Where node `tag` lives, if it exists.
    pub fn get(&self, tag: u64) -> Option<NodeRef> {
        if self.dense.is_empty() {
            self.sparse.get(&tag).copied()
        } else {
            self.dense.get(tag as usize).copied().flatten()
        }
    }
}

/// The nodes of a mesh numbered block after block: node `i` of block `b` has id
/// `block_start[b] + i`. Ids index `coords`, `tags` and `block`; [`NodeTable::id`] finds a
/// tag's id. The numbering depends only on the node blocks, so every stage that builds a
/// table of the same mesh gets the same ids.
pub(crate) struct NodeTable {
    /// Coordinates by id.
    pub coords: Vec<DVec3>,
    /// Node tag by id.
    pub tags: Vec<u64>,
    /// Index of the node block holding each id.
    pub block: Vec<u32>,
    /// First id of each node block.
    pub block_start: Vec<u32>,
    index: NodeIndex,
}

impl NodeTable {
    /// Numbers the nodes of `mesh` in block order.
    pub(crate) fn new(mesh: &Mesh) -> Self {
        let n = mesh.node_count();
        let mut coords = Vec::with_capacity(n);
        let mut tags = Vec::with_capacity(n);
        let mut block = Vec::with_capacity(n);
        let mut block_start = Vec::with_capacity(mesh.node_blocks.len());
        for (bi, b) in mesh.node_blocks.iter().enumerate() {
            debug_assert_eq!(b.tags.len(), b.coords.len());
            block_start.push(coords.len() as u32);
            coords.extend(b.coords.iter().map(|&c| DVec3::from_array(c)));
            tags.extend_from_slice(&b.tags);
            block.resize(coords.len(), bi as u32);
        }
        NodeTable {
            coords,
            tags,
            block,
            block_start,
            index: NodeIndex::new(mesh),
        }
    }

    /// Id of node `tag`, if it exists.
    #[inline]
    pub(crate) fn id(&self, tag: u64) -> Option<u32> {
        self.index
            .get(tag)
            .map(|r| self.block_start[r.block as usize] + r.index)
    }

    /// Block and index of node `tag` in its mesh.
    pub(crate) fn node_ref(&self, tag: u64) -> Option<NodeRef> {
        self.index.get(tag)
    }

    /// Coordinates of node `tag`.
    pub(crate) fn at(&self, tag: u64) -> Option<DVec3> {
        self.id(tag).map(|i| self.coords[i as usize])
    }

    /// `(dim, tag)` of the entity classifying node `id` (`mesh` is the table's mesh).
    #[inline]
    pub(crate) fn entity(&self, mesh: &Mesh, id: u32) -> (i32, i32) {
        let b = &mesh.node_blocks[self.block[id as usize] as usize];
        (b.entity_dim, b.entity_tag)
    }

    /// Ids of an element's first `K` nodes, or the first tag that names no node.
    pub(crate) fn ids<const K: usize>(&self, nodes: &[u64]) -> Result<[u32; K], u64> {
        let mut out = [0u32; K];
        for (o, &t) in out.iter_mut().zip(nodes) {
            *o = self.id(t).ok_or(t)?;
        }
        Ok(out)
    }

    /// The coordinates by id alone (memory: the rest of the table is freed).
    pub(crate) fn into_coords(self) -> Vec<DVec3> {
        self.coords
    }

    /// The tag → id lookup alone (memory: coordinates, tags and blocks are freed, and a
    /// dense lookup holds 4 bytes a tag instead of a [`NodeRef`]'s 12).
    pub(crate) fn into_ids(self) -> NodeIds {
        let id = |r: NodeRef| self.block_start[r.block as usize] + r.index;
        if self.index.dense.is_empty() {
            NodeIds {
                dense: Vec::new(),
                sparse: self
                    .index
                    .sparse
                    .iter()
                    .map(|(&t, &r)| (t, id(r)))
                    .collect(),
            }
        } else {
            NodeIds {
                dense: self
                    .index
                    .dense
                    .iter()
                    .map(|r| r.map_or(NodeIds::ABSENT, id))
                    .collect(),
                sparse: HashMap::new(),
            }
        }
    }
}

/// The tag → id part of a [`NodeTable`] ([`NodeTable::into_ids`]): the same ids, dense by
/// tag or hashed as the table's index, nothing by id.
pub(crate) struct NodeIds {
    /// Id by tag ([`NodeIds::ABSENT`]: no such node); empty when hashed.
    dense: Vec<u32>,
    sparse: HashMap<u64, u32>,
}

impl NodeIds {
    /// No node has this id (ids index a table in memory, so they stay below it).
    const ABSENT: u32 = u32::MAX;

    /// Id of node `tag`, if it exists (as [`NodeTable::id`] of the table it came from).
    #[inline]
    pub(crate) fn id(&self, tag: u64) -> Option<u32> {
        if self.dense.is_empty() {
            self.sparse.get(&tag).copied()
        } else {
            self.dense
                .get(tag as usize)
                .copied()
                .filter(|&i| i != Self::ABSENT)
        }
    }
}

/// Node coordinates straight by tag: the coordinate view of the [`NodeTable`] numbering for
/// lookups in element order, without ids. Where tags are compact it is a table indexed by
/// tag holding the coordinates themselves; else it goes through a [`NodeIndex`] (same rules).
///
/// It stays apart from [`NodeTable`] for speed: the checks that visit every element
/// (validity, the recombination invariants, the input checks) look nodes up in no spatial
/// order, so each lookup is a cache miss, and coordinates indexed by tag make it one miss
/// instead of two (tag → id, id → coordinates). They need no ids, tags or blocks.
pub(crate) enum TagCoords<'m> {
    /// Coordinates by tag; a tag with no node holds [`TagCoords::ABSENT`] (memory: 24 bytes
    /// a tag instead of the 32 of an `Option`).
    Dense(Vec<[f64; 3]>),
    Indexed(&'m Mesh, NodeIndex),
}

impl<'m> TagCoords<'m> {
    /// The bits of the x coordinate that mark a tag with no node in [`TagCoords::Dense`]: a
    /// quiet NaN with a payload. A mesh with a node whose x has exactly these bits gets the
    /// indexed form instead, so no node is ever taken for a missing one.
    const ABSENT: u64 = 0x7ff8_6e6f_6e6f_6465;

    /// The coordinates of `mesh`'s nodes by tag (later duplicates of a tag win).
    pub(crate) fn new(mesh: &'m Mesh) -> Self {
        let marked = || {
            mesh.node_blocks
                .iter()
                .any(|b| b.coords.iter().any(|c| c[0].to_bits() == Self::ABSENT))
        };
        let Some(len) = dense_len(mesh).filter(|_| !marked()) else {
            return TagCoords::Indexed(mesh, NodeIndex::new(mesh));
        };
        let mut dense = vec![[f64::from_bits(Self::ABSENT), 0.0, 0.0]; len];
        for b in &mesh.node_blocks {
            for (&t, c) in b.tags.iter().zip(&b.coords) {
                dense[t as usize] = *c;
            }
        }
        TagCoords::Dense(dense)
    }

    /// The coordinates of node `tag`, if it exists.
    #[inline]
    pub(crate) fn get(&self, tag: u64) -> Option<[f64; 3]> {
        match self {
            TagCoords::Dense(d) => d
                .get(tag as usize)
                .filter(|c| c[0].to_bits() != Self::ABSENT)
                .copied(),
            TagCoords::Indexed(m, index) => index.get(tag).and_then(|r| {
                m.node_blocks
                    .get(r.block as usize)?
                    .coords
                    .get(r.index as usize)
                    .copied()
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::testing::node_block;

    #[test]
    fn tag_coords_tell_missing_tags_from_nodes_whatever_their_coordinates() {
        let absent = f64::from_bits(TagCoords::ABSENT);
        let mut mesh = Mesh::default();
        mesh.node_blocks.push(node_block(
            2,
            vec![1, 3, 4],
            vec![[0.0, 1.0, 2.0], [f64::NAN, 0.0, 0.0], [1.5, -2.0, 0.25]],
        ));
        let dense = TagCoords::new(&mesh);
        assert!(matches!(dense, TagCoords::Dense(_)));
        assert_eq!(dense.get(0), None);
        assert_eq!(dense.get(2), None);
        assert_eq!(dense.get(5), None);
        assert_eq!(dense.get(1), Some([0.0, 1.0, 2.0]));
        assert_eq!(dense.get(4), Some([1.5, -2.0, 0.25]));
        assert!(dense.get(3).is_some_and(|c| c[0].is_nan()));
        // a node at the marker's own bits: still found (the indexed form)
        mesh.node_blocks[0].coords[2] = [absent, 7.0, 8.0];
        let marked = TagCoords::new(&mesh);
        assert!(matches!(marked, TagCoords::Indexed(..)));
        assert_eq!(
            marked.get(4).map(|c| (c[0].to_bits(), c[1], c[2])),
            Some((TagCoords::ABSENT, 7.0, 8.0))
        );
        assert_eq!(marked.get(2), None);
    }

    /// The tag → id lookup kept apart from its table gives the table's ids, repeated tags
    /// (last occurrence) and absent tags included, both dense and hashed.
    #[test]
    fn node_ids_answer_as_the_table_they_came_from() {
        let mut mesh = Mesh::default();
        mesh.node_blocks.push(node_block(
            1,
            vec![5, 2, 9],
            vec![[0.0; 3], [1.0; 3], [2.0; 3]],
        ));
        mesh.node_blocks.push(node_block(
            2,
            vec![7, 2, 1],
            vec![[3.0; 3], [4.0; 3], [5.0; 3]],
        ));
        for sparse in [false, true] {
            if sparse {
                // tags far above 4 × the node count: the hashed form
                mesh.node_blocks[1].tags[0] = 1 << 40;
            }
            let table = NodeTable::new(&mesh);
            let expected: Vec<Option<u32>> =
                (0..12).chain([1 << 40]).map(|t| table.id(t)).collect();
            assert_eq!(
                expected[2],
                Some(4),
                "the last occurrence of a repeated tag"
            );
            assert_eq!(expected.iter().flatten().count(), 5);
            let ids = table.into_ids();
            assert_eq!(ids.dense.is_empty(), sparse);
            let got: Vec<Option<u32>> = (0..12).chain([1 << 40]).map(|t| ids.id(t)).collect();
            assert_eq!(got, expected);
        }
    }
}
