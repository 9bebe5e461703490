//! Where new nodes on edges belong: the curves that hold line elements, the curve an edge
//! lies on by node classification alone, and the parametric coordinates a new node takes
//! from its parents. Shared by every step that splits edges (refinement, the fallback's
//! splits, the second-order nodes).

use super::{etype, Mesh, NodeBlock, NodeIndex};

/// The tags of the curves that hold 2-node line elements, sorted.
pub(crate) fn lined_curves(mesh: &Mesh) -> Vec<i32> {
    let mut lined: Vec<i32> = mesh
        .element_blocks
        .iter()
        .filter(|b| b.element_type == etype::LINE2 && !b.is_empty())
        .map(|b| b.entity_tag)
        .collect();
    lined.sort_unstable();
    lined.dedup();
    lined
}

/// The curve without line elements (not in the sorted `lined`) an edge lies on by node
/// classification alone: both nodes on the same curve, or one on a curve and the other on a
/// point bounding it (the rule of `recombine::topology`'s `CurveInfo::on_curve`). A curve
/// with line elements holds only those: an edge across a surface between two of its nodes
/// is the surface's.
pub(crate) fn classified_curve(
    mesh: &Mesh,
    index: &NodeIndex,
    lined: &[i32],
    a: u64,
    b: u64,
) -> Option<i32> {
    let ent = |t: u64| {
        index.get(t).map(|r| {
            let blk = &mesh.node_blocks[r.block as usize];
            (blk.entity_dim, blk.entity_tag)
        })
    };
    let (ea, eb) = (ent(a)?, ent(b)?);
    let bounds = |curve: i32, point: i32| {
        mesh.entity(1, curve)
            .is_some_and(|e| e.bounding.iter().any(|&p| p.abs() == point))
    };
    let curve = match (ea, eb) {
        ((1, x), (1, y)) if x == y => Some(x),
        ((1, x), (0, p)) | ((0, p), (1, x)) if bounds(x, p) => Some(x),
        _ => None,
    };
    curve.filter(|c| lined.binary_search(c).is_err())
}

/// The mean parametric coordinates of the parent nodes that lie in node block `bi`, and
/// whether all of them do (0 when none does).
pub(crate) fn mean_params(
    blocks: &[NodeBlock],
    index: &NodeIndex,
    bi: usize,
    np: usize,
    refs: &[u64],
) -> (Vec<f64>, bool) {
    let mut uv = vec![0.0; np];
    let mut known = 0usize;
    for &t in refs {
        let Some(r) = index.get(t).filter(|r| r.block as usize == bi) else {
            continue;
        };
        let i = r.index as usize;
        if let Some(p) = blocks[bi]
            .params
            .as_ref()
            .and_then(|p| p.get(i * np..(i + 1) * np))
        {
            for (u, x) in uv.iter_mut().zip(p) {
                *u += x;
            }
            known += 1;
        }
    }
    if known > 0 {
        uv.iter_mut().for_each(|u| *u /= known as f64);
    }
    (uv, known == refs.len())
}
