//! Step 1 of the module doc: the linear copy of a second-order mesh.

use super::*;

/// The linear copy of a second-order mesh (module doc, step 1) and the number of volume
/// elements dropped (with `drop_volumes`; refused otherwise, as the linear job would).
pub fn linearize(input: &Mesh, drop_volumes: bool) -> Result<(Mesh, usize), HighOrderError> {
    let mut volumes: Vec<i32> = Vec::new();
    let mut dropped = 0usize;
    let mut blocks = Vec::with_capacity(input.element_blocks.len());
    let mut high: FastSet<u64> = FastSet::default();
    let existing: FastSet<u64> = input
        .node_blocks
        .iter()
        .flat_map(|b| b.tags.iter().copied())
        .collect();
    for b in &input.element_blocks {
        // the linear job's rule: a block of a type of unknown size is left to the match below
        // (kept when empty, refused as unsupported otherwise)
        crate::recombine::check_block(b)?;
        let k = b.nodes_per_element();
        let dim = element_dim(b.element_type);
        let lower = match (dim, b.element_type) {
            (Some(3), _) => {
                if !b.is_empty() {
                    dropped += b.len();
                    volumes.push(b.entity_tag);
                }
                continue;
            }
            (_, etype::TRI6) => Some(etype::TRI3),
            // quads already in the input (transfinite, layered or recombined faces) stay
            // quads: the linear job keeps them as it keeps any quad
            (_, etype::QUAD9 | etype::QUAD8) => Some(etype::QUAD4),
            (_, etype::LINE3) => Some(etype::LINE2),
            (_, etype::TRI3 | etype::LINE2 | etype::POINT) => None,
            _ if b.is_empty() => None,
            _ => {
                return Err(HighOrderError::Unsupported {
                    dim: b.entity_dim,
                    entity: b.entity_tag,
                    element_type: b.element_type,
                    count: b.len(),
                })
            }
        };
        match lower {
            None => blocks.push(b.clone()),
            Some(t) => {
                let c = element_node_count(t).unwrap_or(0);
                let mut nodes = Vec::with_capacity(b.len() * c);
                for (i, e) in b.nodes.chunks_exact(k).enumerate() {
                    // the linear job checks the corners; the high-order nodes are ours
                    if let Some(&node) = e[c..].iter().find(|n| !existing.contains(n)) {
                        return Err(RecombineError::UnknownNode {
                            dim: b.entity_dim,
                            entity: b.entity_tag,
                            element: b.tags[i],
                            node,
                        }
                        .into());
                    }
                    nodes.extend_from_slice(&e[..c]);
                    high.extend(e[c..].iter().copied());
                }
                blocks.push(ElementBlock {
                    element_type: t,
                    nodes,
                    ..b.clone()
                });
            }
        }
    }
    if dropped > 0 && !drop_volumes {
        volumes.sort_unstable();
        volumes.dedup();
        return Err(RecombineError::VolumeElements {
            count: dropped,
            volumes,
        }
        .into());
    }
    let used: FastSet<u64> = blocks
        .iter()
        .flat_map(|b| b.nodes.iter().copied())
        .collect();
    high.retain(|n| !used.contains(n));
    let mut lin = input.clone();
    lin.element_blocks = blocks;
    if dropped > 0 {
        volumes.sort_unstable();
        volumes.dedup();
        lin.warnings.push(format!(
            "dropped {dropped} volume elements (volumes {}); the volume entities are kept",
            volumes
                .iter()
                .map(|v| v.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    for blk in &mut lin.node_blocks {
        if !blk.tags.iter().any(|t| high.contains(t)) {
            continue;
        }
        let np = blk.entity_dim.max(0) as usize;
        let mut tags = Vec::with_capacity(blk.tags.len());
        let mut coords = Vec::with_capacity(blk.tags.len());
        let mut params = blk.params.as_ref().map(|_| Vec::new());
        for (i, &t) in blk.tags.iter().enumerate() {
            if high.contains(&t) {
                continue;
            }
            tags.push(t);
            coords.push(blk.coords[i]);
            if let (Some(out), Some(p)) = (params.as_mut(), blk.params.as_ref()) {
                out.extend_from_slice(p.get(i * np..(i + 1) * np).unwrap_or(&[]));
            }
        }
        blk.tags = tags;
        blk.coords = coords;
        blk.params = params;
    }
    lin.node_blocks.retain(|b| !b.tags.is_empty());
    for link in &mut lin.periodic {
        link.node_pairs
            .retain(|(a, b)| !high.contains(a) && !high.contains(b));
    }
    Ok((lin, dropped))
}
