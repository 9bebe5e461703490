//! Invariant checks for surface meshes, written independently of the optimizer so tests can
//! run them after every operator: conformity, orientation and boundary consistency.

use crate::mesh::{element_dim, etype, Mesh};
use std::collections::HashMap;

/// (surface tag, from node, to node) of one element's pass along an edge.
type EdgeUse = (i32, u64, u64);

/// Checks that the surface elements (3- and 4-node) of `mesh` form a conforming, consistently
/// oriented mesh:
/// - every element names existing, pairwise distinct nodes, and no two elements use the same
///   node set;
/// - every mesh edge is used by at most two surface elements, or lies on a line element
///   (a curve where several surfaces meet);
/// - two elements of the same surface sharing an edge run through it in opposite directions;
/// - when the mesh has line elements, every edge used by a single surface element is one of
///   them (no hanging node, no hole).
///
/// Returns the first violation found, described in words.
pub fn check_surface_mesh(mesh: &Mesh) -> Result<(), String> {
    let index = mesh.node_index();
    let mut lines: Vec<(u64, u64)> = Vec::new();
    // edge (min, max) -> list of (surface, directed a->b)
    let mut edges: HashMap<(u64, u64), Vec<EdgeUse>> = HashMap::new();
    let mut sets: HashMap<Vec<u64>, u64> = HashMap::new();
    for b in &mesh.element_blocks {
        let dim = element_dim(b.element_type);
        for e in 0..b.len() {
            let el = b.element(e);
            for &t in el {
                if index.get(t).is_none() {
                    return Err(format!("element {} names missing node {t}", b.tags[e]));
                }
            }
            if b.element_type == etype::LINE2 {
                lines.push((el[0].min(el[1]), el[0].max(el[1])));
            }
            if dim != Some(2) || !(b.element_type == etype::TRI3 || b.element_type == etype::QUAD4)
            {
                continue;
            }
            let mut set = el.to_vec();
            set.sort_unstable();
            if set.windows(2).any(|w| w[0] == w[1]) {
                return Err(format!("element {} repeats a node: {el:?}", b.tags[e]));
            }
            if let Some(other) = sets.insert(set, b.tags[e]) {
                return Err(format!(
                    "elements {other} and {} use the same nodes",
                    b.tags[e]
                ));
            }
            for k in 0..el.len() {
                let (a, c) = (el[k], el[(k + 1) % el.len()]);
                edges
                    .entry((a.min(c), a.max(c)))
                    .or_default()
                    .push((b.entity_tag, a, c));
            }
        }
    }
    lines.sort_unstable();
    let is_line = |e: &(u64, u64)| lines.binary_search(e).is_ok();
    for (e, uses) in &edges {
        if uses.len() > 2 && !is_line(e) {
            return Err(format!(
                "edge {e:?} is used by {} elements and is not on a curve",
                uses.len()
            ));
        }
        if uses.len() == 1 && !lines.is_empty() && !is_line(e) {
            return Err(format!(
                "edge {e:?} bounds a single element but is not a curve segment (hole or hanging node)"
            ));
        }
        if uses.len() == 2 && uses[0].0 == uses[1].0 && uses[0].1 == uses[1].1 {
            return Err(format!(
                "edge {e:?}: the two elements of surface {} run through it in the same direction",
                uses[0].0
            ));
        }
    }
    Ok(())
}
