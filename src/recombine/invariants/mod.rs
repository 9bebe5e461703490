//! Invariants of recombination, checked from the two meshes alone. Deliberately simple
//! (sorted edge lists keyed by node tags, one surface at a time) and sharing no code with
//! the recombination itself. It runs on every `quadrangulate` call, so it is linear: its
//! sorts are radix sorts of packed tag pairs (`crate::keysort`), and it is parallel over
//! surfaces (and over its independent sorts within one).

use rayon::prelude::*;

use crate::keysort::sort_pairs;
use crate::mesh::{element_dim, etype, Mesh, TagCoords};

mod edges;
mod geometry;
mod surface;

use edges::*;
use geometry::*;
use surface::*;

fn nodes_text(f: &[u64]) -> String {
    f.iter()
        .map(|t| t.to_string())
        .collect::<Vec<_>>()
        .join(" ")
}

/// The edges a split-set comparison is about.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum EdgeSet {
    /// The 2-node line elements.
    LineElements,
    /// The boundary edges (one face) of a surface.
    Boundary {
        /// Surface entity tag.
        surface: i32,
    },
}

impl std::fmt::Display for EdgeSet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            EdgeSet::LineElements => write!(f, "line elements"),
            EdgeSet::Boundary { surface } => write!(f, "surface {surface} boundary edges"),
        }
    }
}

/// What the invariant check after a stage found broken, with the entities and nodes involved. Its text
/// (`Display`) is one line in words.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum InvariantViolation {
    /// The entities or their physical groups differ.
    #[error("entities (or their physical groups) changed")]
    EntitiesChanged,
    /// The physical names differ.
    #[error("physical names changed")]
    PhysicalNamesChanged,
    /// A surface still has 3-node triangles.
    #[error("surface {surface} still has {count} triangles")]
    TrianglesLeft {
        /// Surface entity tag.
        surface: i32,
        /// Triangles in the block found.
        count: usize,
    },
    /// A node classified on a curve or point moved.
    #[error("node {node} on entity ({}, {}) moved from ({}, {}, {}) to ({}, {}, {})", .entity.0, .entity.1, .from[0], .from[1], .from[2], .to[0], .to[1], .to[2])]
    NodeMoved {
        /// Node tag.
        node: u64,
        /// The node's entity (dimension, tag).
        entity: (i32, i32),
        /// Position before.
        from: [f64; 3],
        /// Position after.
        to: [f64; 3],
    },
    /// A node classified on a curve or point is gone.
    #[error("node {node} on entity ({}, {}) disappeared", .entity.0, .entity.1)]
    NodeDisappeared {
        /// Node tag.
        node: u64,
        /// The node's entity (dimension, tag).
        entity: (i32, i32),
    },
    /// An edge of `after` is neither an edge of `before` nor a piece of one split at new
    /// nodes (it joins two nodes of `before`).
    #[error("{set}: the edge {}-{} is new", .edge.0, .edge.1)]
    NewEdge {
        /// The edges compared.
        set: EdgeSet,
        /// The edge.
        edge: (u64, u64),
    },
    /// A new node is on a number of new edges other than two.
    #[error("{set}: new node {node} is on {halves} of them, not 2")]
    SplitNode {
        /// The edges compared.
        set: EdgeSet,
        /// The new node.
        node: u64,
        /// New edges at it.
        halves: usize,
    },
    /// An edge of `before` is gone without being split.
    #[error("{set}: the edge {}-{} disappeared", .edge.0, .edge.1)]
    EdgeDisappeared {
        /// The edges compared.
        set: EdgeSet,
        /// The edge.
        edge: (u64, u64),
    },
    /// Two new half-edges rebuild an edge `before` does not lose.
    #[error("{set}: the split edge {}-{} was not one of them", .edge.0, .edge.1)]
    UnknownSplit {
        /// The edges compared.
        set: EdgeSet,
        /// The edge the halves rebuild.
        edge: (u64, u64),
    },
    /// A face names a node twice.
    #[error("surface {surface}: the face with nodes {} repeats a node", nodes_text(.nodes))]
    RepeatedNode {
        /// Surface entity tag.
        surface: i32,
        /// The face's nodes.
        nodes: Vec<u64>,
    },
    /// An edge is shared by more than two faces (and was not before).
    #[error("surface {surface}: the edge {}-{} is shared by {faces} faces", .edge.0, .edge.1)]
    EdgeShared {
        /// Surface entity tag.
        surface: i32,
        /// The edge.
        edge: (u64, u64),
        /// Faces using it.
        faces: u32,
    },
    /// A curve segment of `before` is no longer an edge, nor split at a new node.
    #[error("surface {surface}: the curve segment {}-{} is no longer an edge", .segment.0, .segment.1)]
    CurveSegmentLost {
        /// Surface entity tag.
        surface: i32,
        /// The segment.
        segment: (u64, u64),
    },
    /// A face runs an edge against the direction the input's faces run it.
    #[error("surface {surface}: the face with nodes {} runs edge {}->{} against the orientation of the input triangles", nodes_text(.nodes), .edge.0, .edge.1)]
    Orientation {
        /// Surface entity tag.
        surface: i32,
        /// The face's nodes.
        nodes: Vec<u64>,
        /// The edge, as the face runs it.
        edge: (u64, u64),
    },
    /// A face names a node that does not exist.
    #[error("surface {surface}: the {} face with nodes {} has an unknown node", if *.input { "input" } else { "output" }, nodes_text(.nodes))]
    UnknownNode {
        /// Surface entity tag.
        surface: i32,
        /// The face is one of `before` (else of `after`).
        input: bool,
        /// The face's nodes.
        nodes: Vec<u64>,
    },
    /// The area of a planar surface changed (more than 1e-9 relative).
    #[error("surface {surface}: planar area changed from {before} to {after}")]
    AreaChanged {
        /// Surface entity tag.
        surface: i32,
        /// Area before.
        before: f64,
        /// Area after.
        after: f64,
    },
}

/// Checks what recombination promises, comparing the mesh `before` with the result `after`:
///
/// - no 3-node triangle is left on any surface; no face repeats a node;
/// - every edge of a surface is shared by at most two of its faces, and each surface's
///   boundary edges (one face) are those of `before`, where a boundary edge of `before` may
///   have been split at new nodes (parity repair, the fallback: in two, or further where a
///   half was split again); every 2-node line element of `after` is a line element of
///   `before` or a piece of such a split;
/// - edges of line elements that were edges of a surface stay edges of it (curves are not
///   crossed);
/// - nodes classified on curves and points are still there, unmoved;
/// - each planar surface's area is unchanged to 1e-9 relative;
/// - every face keeps the orientation of the triangles it came from (no face uses an edge in
///   the direction opposite to the one the surface's triangles used);
/// - entities and physical groups are identical.
///
/// Returns the first violation found (the lowest surface tag first), with the surface and
/// nodes involved.
pub fn check_invariants(before: &Mesh, after: &Mesh) -> Result<(), InvariantViolation> {
    Before::new(before).check(after)
}

/// Every 2-node line element's edge of `m`, sorted and deduplicated.
fn lines(m: &Mesh) -> Vec<Edge> {
    let mut s = Vec::new();
    for b in &m.element_blocks {
        if b.element_type == etype::LINE2 {
            for i in 0..b.len() {
                let e = b.element(i);
                s.push(undirected(e[0], e[1]));
            }
        }
    }
    sort_pairs(&mut s);
    s.dedup();
    s
}

/// The `before` side of [`check_invariants`], prepared once for any number of results of
/// the same input (nothing here depends on `after`).
pub struct Before<'a> {
    mesh: &'a Mesh,
    /// The coordinates of `mesh` by tag (memory: shared with the validity reference when
    /// the pipeline prepares both).
    index: std::sync::Arc<TagCoords<'a>>,
    lines: Vec<Edge>,
    /// Surfaces with faces in `mesh`, by increasing tag.
    surfaces: Vec<(i32, SurfaceBefore)>,
}

/// One surface of `before`: what [`check_invariants`] derives from them.
struct SurfaceBefore {
    edges: EdgeTable,
    boundary: Vec<Edge>,
    /// Twice the summed vector area of the faces (an error: a face has an unknown node).
    total: Result<[f64; 3], InvariantViolation>,
    /// The unit normal of a planar surface (`None`: not planar, or no area).
    plane: Option<[f64; 3]>,
}

impl<'a> Before<'a> {
    /// Prepares the checks against `before`.
    pub fn new(before: &'a Mesh) -> Self {
        Self::with_coords(before, std::sync::Arc::new(TagCoords::new(before)))
    }

    /// [`Before::new`] with `index`, the coordinates of `before`'s nodes by tag.
    pub(crate) fn with_coords(before: &'a Mesh, index: std::sync::Arc<TagCoords<'a>>) -> Self {
        let lines = lines(before);
        let surfaces = before
            .sorted_surfaces(|b| element_dim(b.element_type) == Some(2))
            .par_iter()
            .map(|&s| (s, SurfaceBefore::new(before, &index, s)))
            .collect();
        Before {
            mesh: before,
            index,
            lines,
            surfaces,
        }
    }

    /// [`check_invariants`] of `after` against this `before`.
    pub fn check(&self, after: &Mesh) -> Result<(), InvariantViolation> {
        self.check_at(after, &TagCoords::new(after))
    }

    /// [`Before::check`] with `ia`, the coordinates of `after`'s nodes by tag.
    pub(crate) fn check_at(&self, after: &Mesh, ia: &TagCoords) -> Result<(), InvariantViolation> {
        let before = self.mesh;
        if before.entities != after.entities {
            return Err(InvariantViolation::EntitiesChanged);
        }
        if before.physical_names != after.physical_names {
            return Err(InvariantViolation::PhysicalNamesChanged);
        }
        for b in &after.element_blocks {
            if b.element_type == etype::TRI3 && !b.is_empty() {
                return Err(InvariantViolation::TrianglesLeft {
                    surface: b.entity_tag,
                    count: b.len(),
                });
            }
        }
        let ib = &*self.index;
        let new_node = |t: u64| ib.get(t).is_none();
        // curve and point nodes unmoved
        for b in &before.node_blocks {
            if b.entity_dim > 1 {
                continue;
            }
            for (t, c) in b.tags.iter().zip(&b.coords) {
                match ia.get(*t) {
                    Some(x) if x == *c => {}
                    Some(x) => {
                        return Err(InvariantViolation::NodeMoved {
                            node: *t,
                            entity: (b.entity_dim, b.entity_tag),
                            from: *c,
                            to: x,
                        })
                    }
                    None => {
                        return Err(InvariantViolation::NodeDisappeared {
                            node: *t,
                            entity: (b.entity_dim, b.entity_tag),
                        })
                    }
                }
            }
        }
        // line elements: kept or split in two at a new node
        let la = lines(after);
        check_split_sets(&self.lines, &la, &new_node, EdgeSet::LineElements)?;
        let mut surfaces = after.sorted_surfaces(|b| element_dim(b.element_type) == Some(2));
        surfaces.extend(self.surfaces.iter().map(|x| x.0));
        surfaces.sort_unstable();
        surfaces.dedup();
        let results: Vec<Result<(), InvariantViolation>> = surfaces
            .par_iter()
            .map(|&s| {
                // a surface with no face before
                let absent;
                let sb = match self.surfaces.binary_search_by_key(&s, |x| x.0) {
                    Ok(i) => &self.surfaces[i].1,
                    Err(_) => {
                        absent = SurfaceBefore::new(before, ib, s);
                        &absent
                    }
                };
                check_surface(self, sb, after, ia, s)
            })
            .collect();
        results.into_iter().collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::testing::{node_block, one_surface};
    use crate::mesh::ElementBlock;

    /// A 3×3-node unit square: corner nodes on points, the rest on the surface; `elems` of
    /// `etype_` on surface 1.
    fn square(etype_: u32, elems: &[&[u64]], moved: Option<(u64, [f64; 3])>) -> Mesh {
        let mut coords: Vec<[f64; 3]> = (0..9)
            .map(|i| [(i % 3) as f64 * 0.5, (i / 3) as f64 * 0.5, 0.0])
            .collect();
        if let Some((t, c)) = moved {
            coords[t as usize - 1] = c;
        }
        let corners = [1u64, 3, 7, 9];
        let blocks = [(0, true), (2, false)].map(|(dim, pick)| {
            let tags: Vec<u64> = (1..=9u64).filter(|t| corners.contains(t) == pick).collect();
            let at = tags.iter().map(|&t| coords[t as usize - 1]).collect();
            node_block(dim, tags, at)
        });
        one_surface(blocks.into(), etype_, elems)
    }

    #[test]
    fn an_edge_may_be_split_once_or_along_a_chain_of_new_nodes() {
        // nodes from 100 on are new
        let new_node = |t: u64| t >= 100;
        let check = |after: &[Edge]| {
            let mut after = after.to_vec();
            after.sort_unstable();
            surface::check_split_sets(&[(1, 2), (2, 3)], &after, &new_node, EdgeSet::LineElements)
        };
        // one split, and a split of a split's half
        assert!(check(&[(1, 100), (2, 100), (2, 3)]).is_ok());
        assert!(check(&[(1, 100), (100, 101), (2, 101), (2, 3)]).is_ok());
        assert!(check(&[(1, 100), (100, 101), (2, 102), (101, 102), (3, 103), (2, 103)]).is_ok());
        // a chain that stops at a new node, or comes back to where it started
        assert!(check(&[(1, 100), (100, 101), (2, 3)]).is_err());
        assert!(check(&[(1, 100), (100, 101), (1, 101), (2, 3)]).is_err());
        // new nodes in a cycle of their own, an edge between two old nodes, a lost edge
        assert!(check(&[(1, 2), (2, 3), (100, 101), (101, 102), (100, 102)]).is_err());
        assert!(check(&[(1, 2), (1, 3), (2, 3)]).is_err());
        assert!(check(&[(2, 3)]).is_err());
        // a chain rebuilding an edge that was not there
        assert!(check(&[(1, 2), (2, 3), (1, 100), (3, 100)]).is_err());
    }

    #[test]
    fn a_curve_segment_split_twice_along_its_chord_is_kept() {
        // a unit square of two triangles with line elements round it; after: the bottom
        // segment 1-2 split at thirds (nodes 100, 101 on the curve) and two quads
        let corners = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
        let lines = |nodes: Vec<u64>| ElementBlock {
            entity_dim: 1,
            entity_tag: 1,
            element_type: etype::LINE2,
            tags: (100..100 + nodes.len() as u64 / 2).collect(),
            nodes,
            partitions: None,
        };
        let mut before = one_surface(
            vec![node_block(0, vec![1, 2, 3, 4], corners.clone())],
            etype::TRI3,
            &[&[1, 2, 3], &[1, 3, 4]],
        );
        before
            .element_blocks
            .push(lines(vec![1, 2, 2, 3, 3, 4, 4, 1]));
        let after_with = |mid: [f64; 3], bottom: Vec<u64>| {
            let mut m = one_surface(
                vec![
                    node_block(0, vec![1, 2, 3, 4], corners.clone()),
                    node_block(1, vec![100, 101], vec![[1.0 / 3.0, 0.0, 0.0], mid]),
                ],
                etype::QUAD4,
                &[&[100, 101, 2, 3], &[1, 100, 3, 4]],
            );
            let mut l = bottom;
            l.extend([2, 3, 3, 4, 4, 1]);
            m.element_blocks.push(lines(l));
            m
        };
        let split = after_with([2.0 / 3.0, 0.0, 0.0], vec![1, 100, 100, 101, 101, 2]);
        assert_eq!(check_invariants(&before, &split), Ok(()));
        assert_eq!(Before::new(&before).check(&split), Ok(()));
        // the bottom line elements not rebuilt: the old segment is lost
        let lost = after_with([2.0 / 3.0, 0.0, 0.0], vec![1, 100, 100, 101]);
        assert!(check_invariants(&before, &lost).is_err());
    }

    /// The edge table answers as a count over the faces, with compact tags (runs) and
    /// with tags too sparse for them (binary search), on edges used once, twice, in both
    /// directions and not at all.
    #[test]
    fn the_edge_table_counts_uses_and_directions_with_and_without_runs() {
        for scale in [1u64, 1 << 40] {
            let t = |i: u64| i * scale;
            let faces: Vec<Vec<u64>> = vec![
                vec![t(1), t(2), t(5)],
                vec![t(1), t(5), t(4)],
                vec![t(2), t(3), t(6), t(5)],
                vec![t(5), t(2), t(7)],
                vec![t(9), t(8), t(4)],
            ];
            let refs: Vec<&[u64]> = faces.iter().map(|f| &f[..]).collect();
            let table = EdgeTable::new(&refs);
            assert_eq!(table.start.is_empty(), scale > 1);
            let uses_of = |p: u64, q: u64| {
                faces
                    .iter()
                    .flat_map(|f| (0..f.len()).map(move |i| (f[i], f[(i + 1) % f.len()])))
                    .filter(|&e| e == (p, q))
                    .count() as u32
            };
            let runs = |p: u64, q: u64| uses_of(p, q) > 0;
            let mut once = Vec::new();
            for p in 0..11 {
                for q in 0..11 {
                    let (p, q) = (t(p), t(q));
                    assert_eq!(table.runs(p, q), runs(p, q), "{p} -> {q}");
                    if p < q {
                        let uses = uses_of(p, q) + uses_of(q, p);
                        assert_eq!(table.count(&(p, q)), uses, "{p} {q}");
                        if uses == 1 {
                            once.push((p, q));
                        }
                    }
                }
            }
            // 2-5 is used three times (twice from 5)
            assert_eq!(table.count(&(t(2), t(5))), 3);
            assert!(once.len() > 5);
            assert_eq!(table.boundary(), once);
        }
    }

    const TRIS: [&[u64]; 8] = [
        &[1, 2, 5],
        &[1, 5, 4],
        &[2, 3, 6],
        &[2, 6, 5],
        &[4, 5, 8],
        &[4, 8, 7],
        &[5, 6, 9],
        &[5, 9, 8],
    ];
    const QUADS: [&[u64]; 4] = [&[1, 2, 5, 4], &[2, 3, 6, 5], &[4, 5, 8, 7], &[5, 6, 9, 8]];

    #[test]
    fn the_prepared_input_finds_what_the_one_call_finds() {
        let before = square(etype::TRI3, &TRIS, None);
        let prepared = Before::new(&before);
        let flipped: [&[u64]; 4] = [&[1, 4, 5, 2], QUADS[1], QUADS[2], QUADS[3]];
        let three: [&[u64]; 5] = [QUADS[0], QUADS[1], QUADS[2], QUADS[3], &[1, 2, 5, 4]];
        let cases = [
            (square(etype::QUAD4, &QUADS, None), None),
            (
                square(etype::TRI3, &TRIS, None),
                Some("still has 8 triangles"),
            ),
            (
                square(etype::QUAD4, &QUADS, Some((3, [1.0, 0.1, 0.0]))),
                Some("node 3 on entity (0, 1) moved"),
            ),
            (
                square(etype::QUAD4, &flipped, None),
                Some("against the orientation"),
            ),
            (
                square(etype::QUAD4, &three, None),
                Some("shared by 3 faces"),
            ),
            (
                square(etype::QUAD4, &QUADS, Some((2, [0.5, 0.1, 0.0]))),
                Some("planar area changed"),
            ),
        ];
        for (after, expected) in &cases {
            let once = check_invariants(&before, after);
            assert_eq!(prepared.check(after), once);
            match expected {
                None => assert_eq!(once, Ok(())),
                Some(text) => {
                    let e = once.expect_err(text).to_string();
                    assert!(e.contains(text), "{e}");
                }
            }
        }
    }
}
