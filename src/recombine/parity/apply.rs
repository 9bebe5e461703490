//! Applying a plan: each chosen segment split at its midpoint, with the triangles, lines
//! and quad chords on it, and the new nodes paired through `$Periodic` links.

use super::*;

/// Applies the splits: a new node at the midpoint of each chosen segment (classified on the
/// segment's curve, or on its first surface when no curve is known), each triangle and 2-node
/// line element holding the segment split in two (the first piece keeps the element's tag,
/// the second gets a fresh one), orientation kept; then the edge of each of `columns` is
/// flipped to join its two new nodes.
pub(crate) fn apply(
    mesh: &mut Mesh,
    nodes: &NodeTable,
    choices: &[Choice],
    columns: &[Column],
) -> Result<Vec<ParitySplit>, RecombineError> {
    let first_node = mesh.max_node_tag() + 1;
    let mut next_elem = mesh.max_element_tag() + 1;
    let mut mids: Vec<((u64, u64), u64)> = Vec::new();
    let mut report = Vec::new();
    // surface of a quad holding each chord edge without a curve
    let mut quad_surface: Vec<(u64, i32)> = choices
        .iter()
        .flat_map(|c| c.with.iter())
        .filter(|w| w.2.is_none())
        .map(|w| (edge_key(w.0, w.1), 0))
        .collect();
    quad_surface.sort_unstable();
    quad_surface.dedup();
    if !quad_surface.is_empty() {
        for b in &mesh.element_blocks {
            if b.entity_dim != 2 || b.element_type != etype::QUAD4 {
                continue;
            }
            for i in 0..b.len() {
                let ids: Vec<u32> = b.element(i).iter().filter_map(|&t| nodes.id(t)).collect();
                for j in 0..ids.len() {
                    let k = edge_key(ids[j], ids[(j + 1) % ids.len()]);
                    if let Ok(p) = quad_surface.binary_search_by_key(&k, |x| x.0) {
                        quad_surface[p].1 = b.entity_tag;
                    }
                }
            }
        }
    }
    let mut tag = first_node;
    // per choice: (segment tags, new node) of every split, for the periodic links
    let mut split_sets: Vec<Vec<((u64, u64), u64)>> = Vec::new();
    for c in choices {
        let mut set = Vec::new();
        let all = std::iter::once((c.a, c.b, c.curve)).chain(c.with.iter().copied());
        for (i, (a, b, curve)) in all.enumerate() {
            let (ta, tb) = (nodes.tags[a as usize], nodes.tags[b as usize]);
            let pos = 0.5 * (nodes.coords[a as usize] + nodes.coords[b as usize]);
            let (dim, ent) = match curve {
                Some(t) => (1, t),
                None => {
                    let k = edge_key(a, b);
                    match quad_surface.binary_search_by_key(&k, |x| x.0) {
                        Ok(p) if quad_surface[p].1 != 0 => (2, quad_surface[p].1),
                        _ => (2, c.surfaces.first().copied().unwrap_or(0)),
                    }
                }
            };
            add_node(mesh, nodes, dim, ent, tag, pos, &[a, b], None);
            mids.push(((ta.min(tb), ta.max(tb)), tag));
            set.push(((ta, tb), tag));
            report.push(ParitySplit {
                curve,
                surfaces: if i == 0 {
                    c.surfaces.clone()
                } else {
                    Vec::new()
                },
                segment: (ta, tb),
                new_node: tag,
                turn: false,
            });
            tag += 1;
        }
        split_sets.push(set);
    }
    link_periodic_splits(mesh, &split_sets);
    mids.sort_unstable();
    let mid = |a: u64, b: u64| {
        mids.binary_search_by_key(&(a.min(b), a.max(b)), |x| x.0)
            .ok()
            .map(|i| mids[i].1)
    };
    for blk in mesh.element_blocks.iter_mut() {
        let k = match blk.element_type {
            etype::TRI3 => 3,
            etype::LINE2 => 2,
            etype::QUAD4 if blk.entity_dim == 2 => 4,
            _ => continue,
        };
        let count = blk.len();
        for i in 0..count {
            let e: Vec<u64> = blk.element(i).to_vec();
            let mut pieces = vec![e];
            let mut changed = true;
            while changed {
                changed = false;
                let mut next = Vec::new();
                for p in pieces {
                    match (0..k).find_map(|j| mid(p[j], p[(j + 1) % k]).map(|m| (j, m))) {
                        Some((j, m)) if k == 3 => {
                            let (x, y, z) = (p[j], p[(j + 1) % 3], p[(j + 2) % 3]);
                            next.push(vec![x, m, z]);
                            next.push(vec![m, y, z]);
                            changed = true;
                        }
                        Some((j, m)) if k == 4 => {
                            // a quad chord: the opposite edge is split too (see quad_chords)
                            let q = |i: usize| p[(j + i) % 4];
                            match mid(q(2), q(3)) {
                                Some(m2) => {
                                    next.push(vec![q(0), m, m2, q(3)]);
                                    next.push(vec![m, q(1), q(2), m2]);
                                    changed = true;
                                }
                                None => next.push(p),
                            }
                        }
                        Some((_, m)) => {
                            next.push(vec![p[0], m]);
                            next.push(vec![m, p[1]]);
                            changed = true;
                        }
                        None => next.push(p),
                    }
                }
                pieces = next;
            }
            if pieces.len() == 1 {
                continue;
            }
            blk.nodes[i * k..(i + 1) * k].copy_from_slice(&pieces[0]);
            let part = blk.partitions.as_ref().and_then(|p| p.get(i).cloned());
            for p in &pieces[1..] {
                blk.tags.push(next_elem);
                next_elem += 1;
                blk.nodes.extend_from_slice(p);
                if let (Some(parts), Some(v)) = (blk.partitions.as_mut(), part.as_ref()) {
                    parts.push(v.clone());
                }
            }
        }
    }
    let tag_of = |n: u32| nodes.tags[n as usize];
    let flips: Vec<(u64, u64, u64, u64)> = columns
        .iter()
        .filter_map(|c| {
            let m = mid(tag_of(c.first.0), tag_of(c.first.1))?;
            let n = mid(tag_of(c.second.0), tag_of(c.second.1))?;
            Some((m, n, tag_of(c.b), tag_of(c.c)))
        })
        .collect();
    flip_columns(mesh, &flips);
    Ok(report)
}

/// Adds node `tag` at `pos` to the node block of entity (`dim`, `ent`) (a new block when the
/// entity has none). When the block is parametric, the new node's parametric coordinates
/// are interpolated from those of the `refs` nodes that are in that block: their mean, or
/// with `weights` (one per ref) their weighted mean, the weights of those in the block
/// scaled to sum 1 (a warning says so when some are not; 0 when none is).
#[allow(clippy::too_many_arguments)]
pub(crate) fn add_node(
    mesh: &mut Mesh,
    nodes: &NodeTable,
    dim: i32,
    ent: i32,
    tag: u64,
    pos: DVec3,
    refs: &[u32],
    weights: Option<&[f64]>,
) {
    let bi = mesh
        .node_blocks
        .iter()
        .position(|bl| bl.entity_dim == dim && bl.entity_tag == ent);
    let Some(bi) = bi else {
        mesh.node_blocks.push(NodeBlock {
            entity_dim: dim,
            entity_tag: ent,
            tags: vec![tag],
            coords: vec![pos.to_array()],
            params: None,
        });
        return;
    };
    let np = dim.max(0) as usize;
    let param_of = |n: u32, mesh: &Mesh| -> Option<Vec<f64>> {
        if nodes.block.get(n as usize).copied() != Some(bi as u32) {
            return None;
        }
        let i = (n - nodes.block_start[bi]) as usize;
        mesh.node_blocks[bi]
            .params
            .as_ref()
            .and_then(|p| p.get(i * np..(i + 1) * np))
            .map(|s| s.to_vec())
    };
    let has_params = mesh.node_blocks[bi].params.is_some();
    let uv = if has_params {
        let known: Vec<(Vec<f64>, f64)> = refs
            .iter()
            .enumerate()
            .filter_map(|(i, &n)| {
                let w = weights.and_then(|w| w.get(i).copied()).unwrap_or(1.0);
                Some((param_of(n, mesh)?, w))
            })
            .collect();
        let total: f64 = known.iter().map(|k| k.1).sum();
        if known.len() < refs.len() {
            mesh.warnings.push(format!(
                "node {tag}: parametric coordinates on entity ({dim}, {ent}) averaged from {} of {} neighbouring nodes (the others are not on that entity)",
                known.len(),
                refs.len()
            ));
        }
        let mut uv = vec![0.0; np];
        for (k, wt) in &known {
            for (u, x) in uv.iter_mut().zip(k) {
                *u += match weights {
                    Some(_) if total > 0.0 => x * wt / total,
                    _ => x / known.len() as f64,
                };
            }
        }
        uv
    } else {
        Vec::new()
    };
    let blk = &mut mesh.node_blocks[bi];
    blk.tags.push(tag);
    blk.coords.push(pos.to_array());
    if let Some(p) = blk.params.as_mut() {
        p.extend_from_slice(&uv);
    }
}

/// Adds to every `$Periodic` link the pairs of new nodes whose segments it pairs: when a
/// link maps the ends of one split segment onto the ends of another split of the same
/// choice, the midpoints are paired too (curve links, and surface links, which list their
/// boundary nodes as well).
pub(super) fn link_periodic_splits(mesh: &mut Mesh, split_sets: &[Vec<((u64, u64), u64)>]) {
    if mesh.periodic.is_empty() || split_sets.iter().all(|s| s.len() < 2) {
        return;
    }
    for link in mesh.periodic.iter_mut() {
        let map: HashMap<u64, u64> = link.node_pairs.iter().copied().collect();
        let mut add = Vec::new();
        for set in split_sets {
            for &((a, b), m) in set {
                let (Some(&a2), Some(&b2)) = (map.get(&a), map.get(&b)) else {
                    continue;
                };
                for &((x, y), m2) in set {
                    if (x, y) == (a2, b2) || (x, y) == (b2, a2) {
                        add.push((m, m2));
                    }
                }
            }
        }
        link.node_pairs.extend(add);
    }
}
