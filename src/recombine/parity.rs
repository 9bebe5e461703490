//! Parity repair (paper eq. 5–6 and section 7 step 1): every triangle region must hold an
//! even number of triangles. Design in the module documentation of [`super`].

use std::collections::HashMap;

use glam::DVec3;

use super::topology::{edge_key, NONE};
use super::{ParitySplit, RecombineError, SurfaceWork};
use crate::mesh::{etype, Mesh, NodeBlock, NodeTable};

/// One odd triangle region.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OddRegion {
    /// Surface entity tag.
    pub surface: i32,
    /// Index of the region inside the surface (regions are the connected parts of the
    /// surface's triangles separated by curves), and the number of regions.
    pub region: (usize, usize),
    /// Number of triangles in the region.
    pub triangles: usize,
}

/// A boundary segment chosen for splitting.
#[derive(Debug, Clone)]
pub(crate) struct Choice {
    /// Global ids of the segment's nodes.
    pub a: u32,
    /// See `a`.
    pub b: u32,
    /// Curve the segment lies on, when known.
    pub curve: Option<i32>,
    /// Surfaces whose parity the split flips.
    pub surfaces: Vec<i32>,
    /// Segments split together with `a`–`b`: its images on periodic curves, or the other
    /// edges of a quad chord (see [`quad_chords`]), with their curve when known.
    pub with: Vec<(u32, u32, Option<i32>)>,
}

/// Result of the parity analysis.
pub(crate) struct Plan {
    /// Odd regions.
    pub odd: Vec<OddRegion>,
    /// Segments to split so that every region becomes even.
    pub choices: Vec<Choice>,
    /// Odd regions the plan cannot fix (no splittable segment connects them to a fix).
    pub unsolved: Vec<OddRegion>,
    /// For each of `unsolved`: true when no split at all flips it (as opposed to splits
    /// that exist but always flip an even number of odd regions).
    pub isolated: Vec<bool>,
}

pub(crate) struct Group {
    curve: Option<i32>,
    /// Regions flipped, sorted.
    sig: Vec<u32>,
    /// (not avoided, no ear beside it, length, a, b) of the best segment so far.
    best: (bool, bool, f64, u32, u32),
    /// Segments split together with the best one (its periodic images, or the rest of a
    /// quad chord), with their curve when known.
    with: Vec<(u32, u32, Option<i32>)>,
}

/// Finds the odd regions and a set of segments whose splits make all of them even: a
/// T-join on the graph whose nodes are the regions plus a "ground" node (see module doc).
/// A segment in `avoid` (sorted edge keys) is split only when no other segment flips the
/// same regions.
pub(crate) fn plan(mesh: &Mesh, nodes: &NodeTable, work: &[SurfaceWork], avoid: &[u64]) -> Plan {
    // regions, their sizes and owners
    let mut offset = Vec::with_capacity(work.len());
    let mut region_surface: Vec<(i32, usize, usize)> = Vec::new();
    let mut size: Vec<usize> = Vec::new();
    for w in work {
        offset.push(size.len() as u32);
        for r in 0..w.n_regions {
            region_surface.push((w.tag, r, w.n_regions));
            size.push(0);
        }
        let base = size.len() - w.n_regions;
        for &r in &w.region {
            size[base + r as usize] += 1;
        }
    }
    let nr = size.len();
    let odd_of = |r: usize| OddRegion {
        surface: region_surface[r].0,
        region: (region_surface[r].1, region_surface[r].2),
        triangles: size[r],
    };
    let odd: Vec<OddRegion> = (0..nr).filter(|&r| size[r] % 2 == 1).map(odd_of).collect();
    if odd.is_empty() {
        return Plan {
            odd,
            choices: Vec::new(),
            unsolved: Vec::new(),
            isolated: Vec::new(),
        };
    }
    // wall half-edges with their region, and whether their triangle is an "ear" (two or
    // three wall edges) or a few graph steps from one: splitting a segment of an ear leaves
    // a half with a single graph neighbour, the other half, so the matching must merge them
    // back into a "quad" with a straight angle at the new node, and an ear nearby forces its
    // neighbours' matches in a chain that often ends the same way; such segments are split
    // only when no other will do
    let mut walls: Vec<(u64, u32, bool)> = Vec::new();
    for (w, &off) in work.iter().zip(&offset) {
        let near_ear = near_ears(&w.topo, 3);
        for (t, &ear) in near_ear.iter().enumerate() {
            let nb = &w.topo.nbr[3 * t..3 * t + 3];
            for k in 0..3 {
                if nb[k] == NONE {
                    let tri = w.topo.tris[t];
                    walls.push((edge_key(tri[k], tri[(k + 1) % 3]), off + w.region[t], ear));
                }
            }
        }
    }
    walls.sort_unstable();
    let blocked = blocked_edges(mesh, nodes);
    let line_curve = line_curves(mesh, nodes);
    let curve_of = |key: u64| -> Option<i32> {
        let (a, b) = ((key >> 32) as u32, key as u32);
        match line_curve.binary_search_by_key(&key, |x| x.0) {
            Ok(p) => Some(line_curve[p].1),
            Err(_) => match (nodes.entity(mesh, a), nodes.entity(mesh, b)) {
                ((1, c), _) | (_, (1, c)) => Some(c),
                // a curve meshed with one segment: the curve bounded by both points
                ((0, p), (0, q)) => mesh.entities[1]
                    .iter()
                    .find(|c| {
                        let pts: Vec<i32> = c.bounding.iter().map(|x| x.abs()).collect();
                        pts.len() == 2 && pts.contains(&p) && pts.contains(&q)
                    })
                    .map(|c| c.tag),
                _ => None,
            },
        }
    };
    // regions flipped by splitting the segment `key` (odd number of triangles on it)
    let sig_of = |key: u64| -> Vec<u32> {
        let lo = walls.partition_point(|x| x.0 < key);
        let hi = walls.partition_point(|x| x.0 <= key);
        walls[lo..hi]
            .chunk_by(|x, y| x.1 == y.1)
            .filter(|r| r.len() % 2 == 1)
            .map(|r| r[0].1)
            .collect()
    };
    let periodic = PeriodicCurves::new(mesh, nodes);
    let periodic_surfaces = PeriodicSurfaces::new(mesh, nodes);
    let mut groups: HashMap<(Option<i32>, Vec<u32>), usize> = HashMap::new();
    let mut list: Vec<Group> = Vec::new();
    for run in walls.chunk_by(|x, y| x.0 == y.0) {
        let key = run[0].0;
        if blocked.binary_search(&key).is_ok() {
            continue;
        }
        let (a, b) = ((key >> 32) as u32, key as u32);
        let curve = curve_of(key);
        let mut sig = sig_of(key);
        // a segment of a periodic curve is split together with its images on the curves
        // linked to it; the split flips the regions of all of them
        let mut with: Vec<(u32, u32, Option<i32>)> = Vec::new();
        let mut class = curve;
        if let Some(c) = curve.filter(|&c| periodic.has(c)) {
            let Some(images) = periodic.images(c, a, b) else {
                continue;
            };
            for &(c2, x, y) in &images {
                let k2 = edge_key(x, y);
                if blocked.binary_search(&k2).is_ok() {
                    sig.clear();
                    break;
                }
                sig = xor_sorted(&sig, &sig_of(k2));
                with.push((x, y, Some(c2)));
            }
            class = images.iter().map(|i| i.0).chain([c]).min();
        } else if !periodic_surfaces.is_empty() {
            // a segment on the boundary of a periodic surface whose curve is not known
            // (no curve data, e.g. MSH 2.2 without line elements): split together with its
            // images through the surface links, so the slave stays the master's image
            let Some(images) = periodic_surfaces.images(a, b) else {
                continue;
            };
            for &(x, y) in &images {
                let k2 = edge_key(x, y);
                if blocked.binary_search(&k2).is_ok() {
                    sig.clear();
                    break;
                }
                sig = xor_sorted(&sig, &sig_of(k2));
                with.push((x, y, None));
            }
        }
        if sig.is_empty() {
            continue;
        }
        let len = (nodes.coords[a as usize] - nodes.coords[b as usize]).length();
        let no_ear = run.iter().all(|x| !x.2);
        let wanted = avoid.binary_search(&key).is_err();
        let id = *groups.entry((class, sig.clone())).or_insert_with(|| {
            list.push(Group {
                curve,
                sig,
                best: (false, false, -1.0, a, b),
                with: Vec::new(),
            });
            list.len() - 1
        });
        let best = list[id].best;
        if (wanted, no_ear, len) > (best.0, best.1, best.2) {
            list[id].best = (wanted, no_ear, len, a, b);
            list[id].curve = curve;
            list[id].with = with;
        }
    }
    let odd_in: Vec<bool> = size.iter().map(|s| s % 2 == 1).collect();
    let (mut chosen, mut unsolved_ids) = solve_groups(&list, &odd_in);
    // a mixed surface left odd is retriangulated and recombined whole (see `recombine`),
    // which gives better quads than a chord through its own quads; chords are for triangle
    // surfaces bordered by other surfaces' quads (structured `Layers`/`Recombine` faces)
    let mixed = |r: u32| {
        let s = region_surface[r as usize].0;
        work.iter().any(|w| w.tag == s && w.quads_kept > 0)
    };
    if !unsolved_ids.is_empty() && !blocked.is_empty() && !unsolved_ids.iter().any(|&r| mixed(r)) {
        // segments bordered by quads: the split runs through the quad strip (chord) that
        // starts there, splitting each quad into two, until it leaves the quads
        // a chord edge is on a curve when a line element holds it or both ends are
        // classified on that curve (no line elements)
        let chord_curve = |key: u64| -> Option<i32> {
            match line_curve.binary_search_by_key(&key, |x| x.0) {
                Ok(p) => Some(line_curve[p].1),
                Err(_) => match (
                    nodes.entity(mesh, (key >> 32) as u32),
                    nodes.entity(mesh, key as u32),
                ) {
                    ((1, c), (1, d)) if c == d => Some(c),
                    _ => None,
                },
            }
        };
        let chords = quad_chords(
            mesh,
            nodes,
            &walls,
            &blocked,
            &curve_of,
            &chord_curve,
            &periodic,
        );
        let mut by_sig: HashMap<Vec<u32>, usize> = HashMap::new();
        for ch in chords {
            let sig = ch.iter().fold(Vec::new(), |acc, e| {
                xor_sorted(&acc, &sig_of(edge_key(e.0, e.1)))
            });
            if sig.is_empty() {
                continue;
            }
            match by_sig.get(&sig) {
                Some(&g) if list[g].with.len() <= ch.len() => {}
                _ => {
                    let (a, b, curve) = ch[0];
                    let grp = Group {
                        curve,
                        sig: sig.clone(),
                        best: (true, true, 0.0, a, b),
                        with: ch[1..].to_vec(),
                    };
                    match by_sig.get(&sig) {
                        Some(&g) => list[g] = grp,
                        None => {
                            by_sig.insert(sig, list.len());
                            list.push(grp);
                        }
                    }
                }
            }
        }
        (chosen, unsolved_ids) = solve_groups(&list, &odd_in);
    }
    let mut touched = vec![false; nr];
    for g in &list {
        for &r in &g.sig {
            touched[r as usize] = true;
        }
    }
    let isolated: Vec<bool> = unsolved_ids.iter().map(|&r| !touched[r as usize]).collect();
    let unsolved: Vec<OddRegion> = unsolved_ids
        .into_iter()
        .map(|r| odd_of(r as usize))
        .collect();
    // a group chosen twice cancels out
    chosen.sort_unstable();
    let keep: Vec<usize> = chosen
        .chunk_by(|a, b| a == b)
        .filter(|r| r.len() % 2 == 1)
        .map(|r| r[0])
        .collect();
    let choices = keep
        .into_iter()
        .map(|g| {
            let grp = &list[g];
            let mut surfaces: Vec<i32> = grp
                .sig
                .iter()
                .map(|&r| region_surface[r as usize].0)
                .collect();
            surfaces.sort_unstable();
            surfaces.dedup();
            Choice {
                a: grp.best.3,
                b: grp.best.4,
                curve: grp.curve,
                surfaces,
                with: grp.with.clone(),
            }
        })
        .collect();
    Plan {
        odd,
        choices,
        unsolved,
        isolated,
    }
}

/// " (region 1 of 3, separated by embedded curves)" when `o`'s surface has several regions,
/// else nothing.
pub(crate) fn region_note(o: &OddRegion) -> String {
    if o.region.1 > 1 {
        format!(
            " (region {} of {}, separated by embedded curves)",
            o.region.0 + 1,
            o.region.1
        )
    } else {
        String::new()
    }
}

/// "surface 2 (region 1 of 3, separated by embedded curves) has 117 triangles (odd)".
fn describe(o: &OddRegion) -> String {
    format!(
        "surface {}{} has {} triangles (odd)",
        o.surface,
        region_note(o),
        o.triangles
    )
}

/// Why the odd regions `unsolved` cannot be made even, in plain words.
pub(crate) fn unsolvable_message(unsolved: &[OddRegion], isolated: &[bool]) -> String {
    let mut lines = Vec::new();
    let mut rest = Vec::new();
    for (o, &iso) in unsolved.iter().zip(isolated) {
        if iso {
            lines.push(format!(
                "{}; no segment around it can be split: every curve around it is closed on itself \
                 (a seam with the surface on both sides), periodic with images that cancel the \
                 split, or bordered by quads whose strip cannot be split",
                describe(o)
            ));
        } else {
            rest.push(describe(o));
        }
    }
    if !rest.is_empty() {
        lines.push(format!(
            "{}; every split of the curves around {} changes an even number of odd surfaces, \
             so an odd one always remains",
            rest.join(", "),
            if rest.len() == 1 { "it" } else { "them" }
        ));
    }
    format!(
        "cannot make every surface even by splitting boundary segments: {}; remesh with a \
         different size, or with an odd number of nodes on one of its curves",
        lines.join("; ")
    )
}

/// [`RecombineError::ParityUnsolvable`] for a plan with unsolved regions.
pub(crate) fn unsolvable_error(plan: &Plan) -> RecombineError {
    RecombineError::ParityUnsolvable {
        regions: plan.unsolved.clone(),
        message: unsolvable_message(&plan.unsolved, &plan.isolated),
    }
}

/// [`RecombineError::ParityUnsolvable`] when regions are still odd after the splits (a bug:
/// the plan said they would be even).
pub(crate) fn still_odd_error(odd: &[OddRegion]) -> RecombineError {
    let list: Vec<String> = odd.iter().map(describe).collect();
    RecombineError::ParityUnsolvable {
        regions: odd.to_vec(),
        message: format!(
            "parity repair split boundary segments but {} still odd (an internal error; \
             please report it with the input mesh)",
            if list.len() == 1 {
                format!("{} is", list[0])
            } else {
                format!("{} are", list.join(", "))
            }
        ),
    }
}

/// Triangles within `depth` graph steps of an *ear* (a triangle with two or three wall
/// edges), found by a breadth-first search from all ears.
fn near_ears(topo: &super::topology::SurfaceTopo, depth: u8) -> Vec<bool> {
    let n = topo.len();
    let mut dist = vec![u8::MAX; n];
    let mut queue: Vec<usize> = (0..n)
        .filter(|&t| {
            topo.nbr[3 * t..3 * t + 3]
                .iter()
                .filter(|&&x| x == NONE)
                .count()
                >= 2
        })
        .collect();
    for &t in &queue {
        dist[t] = 0;
    }
    let mut head = 0;
    while head < queue.len() {
        let t = queue[head];
        head += 1;
        if dist[t] >= depth {
            continue;
        }
        for &u in &topo.nbr[3 * t..3 * t + 3] {
            if u != NONE && dist[u as usize] == u8::MAX {
                dist[u as usize] = dist[t] + 1;
                queue.push(u as usize);
            }
        }
    }
    dist.into_iter().map(|d| d <= depth).collect()
}

/// Keys of edges of 2D elements other than 3-node triangles (quads …): splitting them would
/// leave a hanging node.
fn blocked_edges(mesh: &Mesh, nodes: &NodeTable) -> Vec<u64> {
    let mut out = Vec::new();
    for b in &mesh.element_blocks {
        if b.entity_dim != 2 || b.element_type == etype::TRI3 {
            continue;
        }
        let k = b.nodes_per_element();
        let corners = if b.element_type == etype::QUAD4 { 4 } else { k };
        for i in 0..b.len() {
            let e = b.element(i);
            let ids: Vec<u32> = e.iter().filter_map(|&t| nodes.id(t)).collect();
            if ids.len() != e.len() || corners == 0 {
                continue;
            }
            for c in 0..corners {
                out.push(edge_key(ids[c], ids[(c + 1) % corners]));
            }
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// `(edge key, curve tag)` of every 2-node line element, sorted by key.
fn line_curves(mesh: &Mesh, nodes: &NodeTable) -> Vec<(u64, i32)> {
    let mut out = Vec::new();
    for b in &mesh.element_blocks {
        if b.element_type != etype::LINE2 {
            continue;
        }
        for i in 0..b.len() {
            let e = b.element(i);
            if let (Some(x), Some(y)) = (nodes.id(e[0]), nodes.id(e[1])) {
                out.push((edge_key(x, y), b.entity_tag));
            }
        }
    }
    out.sort_unstable();
    out
}

/// Applies the splits: a new node at the midpoint of each chosen segment (classified on the
/// segment's curve, or on its first surface when no curve is known), each triangle and 2-node
/// line element holding the segment split in two (the first piece keeps the element's tag,
/// the second gets a fresh one), orientation kept.
pub(crate) fn apply(
    mesh: &mut Mesh,
    nodes: &NodeTable,
    choices: &[Choice],
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
            add_node(mesh, nodes, dim, ent, tag, pos, &[a, b]);
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
    Ok(report)
}

/// Adds node `tag` at `pos` to the node block of entity (`dim`, `ent`) (a new block when the
/// entity has none). When the block is parametric, the new node's parametric coordinates
/// are the mean of those of the `refs` nodes that are in that block (a warning says so when
/// some are not; 0 when none is).
pub(crate) fn add_node(
    mesh: &mut Mesh,
    nodes: &NodeTable,
    dim: i32,
    ent: i32,
    tag: u64,
    pos: DVec3,
    refs: &[u32],
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
        let known: Vec<Vec<f64>> = refs.iter().filter_map(|&n| param_of(n, mesh)).collect();
        if known.len() < refs.len() {
            mesh.warnings.push(format!(
                "node {tag}: parametric coordinates on entity ({dim}, {ent}) averaged from {} of {} neighbouring nodes (the others are not on that entity)",
                known.len(),
                refs.len()
            ));
        }
        let mut uv = vec![0.0; np];
        for k in &known {
            for (u, x) in uv.iter_mut().zip(k) {
                *u += x / known.len() as f64;
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

/// Fallback T-join over a spanning forest (used when the odd regions are too many for
/// [`min_tjoin`] or some cannot be paired): odd parity is pushed from the leaves to the root
/// of each tree; a root left odd is fixed through a ground group reached along the tree.
/// Returns the chosen groups (with repeats) and the roots that stay odd.
fn tree_tjoin(adj: &[Vec<(u32, usize)>], odd: &[bool], ground: u32) -> (Vec<usize>, Vec<u32>) {
    let nr = odd.len();
    let mut parity: Vec<bool> = odd.to_vec();
    parity.push(false);
    let mut seen = vec![false; nr + 1];
    let mut chosen: Vec<usize> = Vec::new();
    let mut unsolved: Vec<u32> = Vec::new();
    for start in 0..nr {
        if seen[start] {
            continue;
        }
        // component over region-region edges
        let mut comp = vec![start as u32];
        seen[start] = true;
        let mut parent: HashMap<u32, (u32, usize)> = HashMap::new();
        let mut q = 0;
        while q < comp.len() {
            let u = comp[q];
            q += 1;
            for &(v, g) in &adj[u as usize] {
                if v != ground && !seen[v as usize] {
                    seen[v as usize] = true;
                    parent.insert(v, (u, g));
                    comp.push(v);
                }
            }
        }
        if !comp.iter().any(|&r| parity[r as usize]) {
            continue;
        }
        // re-root at a region with a ground group, when there is one, by pushing the
        // odd parity along tree paths to `start` and then from `start` to that region
        for &u in comp.iter().skip(1).rev() {
            if parity[u as usize] {
                let (p, g) = parent[&u];
                parity[u as usize] = false;
                parity[p as usize] ^= true;
                chosen.push(g);
            }
        }
        if parity[start] {
            let ground_at = comp.iter().find_map(|&r| {
                adj[r as usize]
                    .iter()
                    .find(|&&(v, _)| v == ground)
                    .map(|&(_, g)| (r, g))
            });
            match ground_at {
                Some((r, g)) => {
                    // path start -> r in the tree: toggle edges from r up to start
                    let mut x = r;
                    while x != start as u32 {
                        let (p, pg) = parent[&x];
                        chosen.push(pg);
                        x = p;
                    }
                    chosen.push(g);
                    parity[start] = false;
                }
                None => unsolved.push(start as u32),
            }
        }
    }
    (chosen, unsolved)
}

/// Minimum T-join (fewest splits): the odd regions are paired, or paired with the ground, by
/// a minimum-cost perfect matching on shortest-path distances in the region graph
/// (each odd region `i` has a ground twin `K + i` joined to it at its distance to the ground;
/// twins are joined to each other at cost 0), then the groups along each pair's shortest path
/// are chosen. `None` when there are too many odd regions or no pairing exists.
fn min_tjoin(adj: &[Vec<(u32, usize)>], odd: &[u32], ground: u32) -> Option<Vec<usize>> {
    let k = odd.len();
    let nr = adj.len();
    if k == 0 {
        return Some(Vec::new());
    }
    if k > 1500 {
        return None;
    }
    // BFS from each odd region over region-region edges (not through the ground)
    let bfs = |src: u32| -> (Vec<u32>, Vec<(u32, usize)>, Vec<u32>) {
        let mut dist = vec![NONE; nr];
        let mut parent = vec![(NONE, 0usize); nr];
        let mut order = vec![src];
        dist[src as usize] = 0;
        let mut q = 0;
        while q < order.len() {
            let u = order[q];
            q += 1;
            for &(v, g) in &adj[u as usize] {
                if v != ground && dist[v as usize] == NONE {
                    dist[v as usize] = dist[u as usize] + 1;
                    parent[v as usize] = (u, g);
                    order.push(v);
                }
            }
        }
        (dist, parent, order)
    };
    let ground_group = |r: u32| adj[r as usize].iter().find(|e| e.0 == ground).map(|e| e.1);
    let mut edges: Vec<(u32, u32, i64)> = Vec::new();
    for (i, &src) in odd.iter().enumerate() {
        let (dist, _, order) = bfs(src);
        for (j, &dst) in odd.iter().enumerate().skip(i + 1) {
            if dist[dst as usize] != NONE {
                edges.push((i as u32, j as u32, dist[dst as usize] as i64));
            }
        }
        if let Some(r) = order.iter().find(|&&r| ground_group(r).is_some()) {
            edges.push((i as u32, (k + i) as u32, dist[*r as usize] as i64 + 1));
        }
        for j in i + 1..k {
            edges.push(((k + i) as u32, (k + j) as u32, 0));
        }
    }
    let m = crate::matching::solve(2 * k, &edges).ok()?;
    let mut chosen = Vec::new();
    for (i, &src) in odd.iter().enumerate() {
        let mate = m.mate[i] as usize;
        if mate < i {
            continue;
        }
        let (_, parent, order) = bfs(src);
        let end = if mate < k {
            odd[mate]
        } else {
            let r = *order.iter().find(|&&r| ground_group(r).is_some())?;
            chosen.push(ground_group(r)?);
            r
        };
        let mut x = end;
        while x != src {
            let (p, g) = parent[x as usize];
            if p == NONE {
                return None;
            }
            chosen.push(g);
            x = p;
        }
    }
    Some(chosen)
}

/// Chooses groups (with repeats, which cancel) whose splits make every region even, given
/// each group's flipped regions (`sig`) and the odd regions. Returns the choice and the odd
/// regions left that no choice can fix (empty exactly when the GF(2) system "the chosen
/// groups flip every odd region an odd number of times and every even one an even number"
/// is solvable).
///
/// Groups flipping one or two regions are the edges of the region graph (a one-region
/// group joins its region to the ground). Inside one connected component of that graph any
/// even set of odd regions can be fixed along paths, and any set at all when the component
/// holds the ground; so the only constraint is one parity bit per ungrounded component.
/// Groups flipping three or more regions (curves shared by 3+ surfaces) change those bits:
/// a small GF(2) system (rows: ungrounded components, columns: such groups), solved by
/// Gaussian elimination, picks the ones to split; their flips are applied, and the region
/// graph's minimum T-join fixes the rest with the fewest splits.
pub(crate) fn solve_groups(list: &[Group], odd_in: &[bool]) -> (Vec<usize>, Vec<u32>) {
    let nr = odd_in.len();
    let ground = nr as u32;
    // components of the region graph
    let mut uf: Vec<u32> = (0..=nr as u32).collect();
    fn find(uf: &mut [u32], mut x: u32) -> u32 {
        while uf[x as usize] != x {
            let p = uf[uf[x as usize] as usize];
            uf[x as usize] = p;
            x = p;
        }
        x
    }
    let mut adj: Vec<Vec<(u32, usize)>> = vec![Vec::new(); nr + 1];
    for (g, grp) in list.iter().enumerate() {
        let (u, v) = match grp.sig.len() {
            1 => (grp.sig[0], ground),
            2 => (grp.sig[0], grp.sig[1]),
            _ => continue,
        };
        adj[u as usize].push((v, g));
        adj[v as usize].push((u, g));
        let (ru, rv) = (find(&mut uf, u), find(&mut uf, v));
        if ru != rv {
            uf[ru as usize] = rv;
        }
    }
    let ground_root = find(&mut uf, ground);
    let comp: Vec<u32> = (0..nr as u32).map(|r| find(&mut uf, r)).collect();
    // dense numbering of the ungrounded components
    let mut row_of = vec![NONE; nr + 1];
    let mut n_rows = 0usize;
    for &c in &comp {
        if c != ground_root && row_of[c as usize] == NONE {
            row_of[c as usize] = n_rows as u32;
            n_rows += 1;
        }
    }
    let mut rhs = vec![false; n_rows];
    for r in 0..nr {
        let row = row_of[comp[r] as usize];
        if odd_in[r] && row != NONE {
            rhs[row as usize] ^= true;
        }
    }
    let mut odd = odd_in.to_vec();
    let mut chosen: Vec<usize> = Vec::new();
    if rhs.iter().any(|&b| b) {
        // columns: groups flipping 3+ regions, by the ungrounded components they flip
        let mut cols: Vec<(usize, Vec<u32>)> = Vec::new();
        for (g, grp) in list.iter().enumerate() {
            if grp.sig.len() < 3 {
                continue;
            }
            let mut rows: Vec<u32> = grp
                .sig
                .iter()
                .map(|&r| row_of[comp[r as usize] as usize])
                .filter(|&x| x != NONE)
                .collect();
            rows.sort_unstable();
            let rows: Vec<u32> = rows
                .chunk_by(|a, b| a == b)
                .filter(|c| c.len() % 2 == 1)
                .map(|c| c[0])
                .collect();
            if !rows.is_empty() {
                cols.push((g, rows));
            }
        }
        let x = gf2_solve(
            n_rows,
            &cols.iter().map(|c| c.1.clone()).collect::<Vec<_>>(),
            &rhs,
        );
        for (j, (g, _)) in cols.iter().enumerate() {
            if x[j] {
                chosen.push(*g);
                for &r in &list[*g].sig {
                    odd[r as usize] ^= true;
                }
            }
        }
    }
    // components still odd cannot be fixed: their odd regions are reported, and left out of
    // the T-join (one per component would make it impossible)
    let mut left = vec![false; n_rows];
    for r in 0..nr {
        let row = row_of[comp[r] as usize];
        if odd[r] && row != NONE {
            left[row as usize] ^= true;
        }
    }
    let mut unsolved: Vec<u32> = Vec::new();
    for r in 0..nr {
        let row = row_of[comp[r] as usize];
        if row != NONE && left[row as usize] && odd[r] {
            unsolved.push(r as u32);
            odd[r] = false;
        }
    }
    let odd_ids: Vec<u32> = (0..nr as u32).filter(|&r| odd[r as usize]).collect();
    match min_tjoin(&adj, &odd_ids, ground) {
        Some(c) => chosen.extend(c),
        None => {
            let (c, u) = tree_tjoin(&adj, &odd, ground);
            chosen.extend(c);
            unsolved.extend(u);
        }
    }
    unsolved.sort_unstable();
    unsolved.dedup();
    (chosen, unsolved)
}

/// Solves `A x = b` over GF(2) by Gaussian elimination; `cols[j]` lists the rows where
/// column `j` has a 1. Free variables are 0. When the system is inconsistent, the returned
/// `x` satisfies the rows it can (the caller checks what is left).
fn gf2_solve(n_rows: usize, cols: &[Vec<u32>], b: &[bool]) -> Vec<bool> {
    let nc = cols.len();
    let words = (nc + 1).div_ceil(64);
    let mut m = vec![0u64; n_rows * words];
    for (j, c) in cols.iter().enumerate() {
        for &r in c {
            m[r as usize * words + j / 64] ^= 1 << (j % 64);
        }
    }
    for (r, &v) in b.iter().enumerate() {
        if v {
            m[r * words + nc / 64] ^= 1 << (nc % 64);
        }
    }
    let bit = |m: &[u64], r: usize, j: usize| (m[r * words + j / 64] >> (j % 64)) & 1 == 1;
    let mut pivot_row = 0;
    let mut pivots: Vec<(usize, usize)> = Vec::new();
    for j in 0..nc {
        let Some(p) = (pivot_row..n_rows).find(|&r| bit(&m, r, j)) else {
            continue;
        };
        if p != pivot_row {
            for w in 0..words {
                m.swap(p * words + w, pivot_row * words + w);
            }
        }
        for r in 0..n_rows {
            if r != pivot_row && bit(&m, r, j) {
                for w in 0..words {
                    let v = m[pivot_row * words + w];
                    m[r * words + w] ^= v;
                }
            }
        }
        pivots.push((pivot_row, j));
        pivot_row += 1;
        if pivot_row == n_rows {
            break;
        }
    }
    let mut x = vec![false; nc];
    for (r, j) in pivots {
        x[j] = bit(&m, r, nc);
    }
    x
}

/// Symmetric difference of two sorted lists.
fn xor_sorted(x: &[u32], y: &[u32]) -> Vec<u32> {
    let mut out = Vec::with_capacity(x.len() + y.len());
    let (mut i, mut j) = (0, 0);
    while i < x.len() || j < y.len() {
        if j == y.len() || (i < x.len() && x[i] < y[j]) {
            out.push(x[i]);
            i += 1;
        } else if i == x.len() || y[j] < x[i] {
            out.push(y[j]);
            j += 1;
        } else {
            i += 1;
            j += 1;
        }
    }
    out
}

/// Sorted `(from, to)` node pairs (global ids).
type NodeMap = Vec<(u32, u32)>;

/// The `$Periodic` links between curves, as node maps both ways (global ids).
pub(crate) struct PeriodicCurves {
    /// Per link: (slave curve, master curve, slave → master, master → slave).
    links: Vec<(i32, i32, NodeMap, NodeMap)>,
    /// Every curve in some link, sorted.
    curves: Vec<i32>,
}

/// The `$Periodic` links of dimension `dim` as (slave, master, slave → master, master →
/// slave) node maps, and every entity in some link, sorted.
type PeriodicLinks = Vec<(i32, i32, NodeMap, NodeMap)>;

fn periodic_links(mesh: &Mesh, nodes: &NodeTable, dim: i32) -> (PeriodicLinks, Vec<i32>) {
    let mut links = Vec::new();
    let mut tags = Vec::new();
    for l in mesh.periodic.iter().filter(|l| l.dim == dim) {
        let mut fwd: Vec<(u32, u32)> = l
            .node_pairs
            .iter()
            .filter_map(|&(s, m)| Some((nodes.id(s)?, nodes.id(m)?)))
            .collect();
        let mut back: Vec<(u32, u32)> = fwd.iter().map(|&(s, m)| (m, s)).collect();
        fwd.sort_unstable();
        back.sort_unstable();
        links.push((l.tag, l.master_tag, fwd, back));
        tags.extend([l.tag, l.master_tag]);
    }
    tags.sort_unstable();
    tags.dedup();
    (links, tags)
}

impl PeriodicCurves {
    fn new(mesh: &Mesh, nodes: &NodeTable) -> Self {
        let (links, curves) = periodic_links(mesh, nodes, 1);
        PeriodicCurves { links, curves }
    }

    fn has(&self, c: i32) -> bool {
        self.curves.binary_search(&c).is_ok()
    }

    /// The images of segment `a`–`b` of curve `c` on every curve linked to it (directly or
    /// through a chain of links), as `(curve, a', b')`; `None` when some link lacks the
    /// correspondence of an end node (the split could not be mirrored).
    fn images(&self, c: i32, a: u32, b: u32) -> Option<Vec<(i32, u32, u32)>> {
        let look =
            |m: &[(u32, u32)], x: u32| m.binary_search_by_key(&x, |p| p.0).ok().map(|i| m[i].1);
        let mut seen = vec![(c, a, b)];
        let mut head = 0;
        while head < seen.len() {
            let (cc, x, y) = seen[head];
            head += 1;
            for (s, m, fwd, back) in &self.links {
                let (to, map) = if *s == cc {
                    (*m, fwd)
                } else if *m == cc {
                    (*s, back)
                } else {
                    continue;
                };
                if seen.iter().any(|q| q.0 == to) {
                    continue;
                }
                seen.push((to, look(map, x)?, look(map, y)?));
            }
        }
        Some(seen.split_off(1))
    }
}

/// The `$Periodic` links between surfaces, with the edges of their slave and master
/// surfaces: a segment on the boundary of one of them is split together with its images
/// (used when the segment's curve is not known, so the curve links cannot be).
pub(crate) struct PeriodicSurfaces {
    /// Per link: (slave, master, slave → master, master → slave).
    links: Vec<(i32, i32, NodeMap, NodeMap)>,
    /// (edge key, surface) of every element edge of a surface in some link, sorted.
    edges: Vec<(u64, i32)>,
}

impl PeriodicSurfaces {
    fn new(mesh: &Mesh, nodes: &NodeTable) -> Self {
        let (links, surfaces) = periodic_links(mesh, nodes, 2);
        let mut edges = Vec::new();
        if !links.is_empty() {
            for b in &mesh.element_blocks {
                if b.entity_dim != 2
                    || (b.element_type != etype::TRI3 && b.element_type != etype::QUAD4)
                    || surfaces.binary_search(&b.entity_tag).is_err()
                {
                    continue;
                }
                for i in 0..b.len() {
                    let e = b.element(i);
                    for j in 0..e.len() {
                        if let (Some(x), Some(y)) = (nodes.id(e[j]), nodes.id(e[(j + 1) % e.len()]))
                        {
                            edges.push((edge_key(x, y), b.entity_tag));
                        }
                    }
                }
            }
            edges.sort_unstable();
            edges.dedup();
        }
        PeriodicSurfaces { links, edges }
    }

    fn is_empty(&self) -> bool {
        self.links.is_empty()
    }

    fn on(&self, key: u64, surface: i32) -> bool {
        self.edges.binary_search(&(key, surface)).is_ok()
    }

    /// The images of segment `a`–`b` through the surface links (directly or through a
    /// chain of them): for each link whose slave (master) has the segment as an element
    /// edge, its image on the master (slave), which must be an element edge there. `None`
    /// when some link lacks the correspondence of an end node or the image is not an edge
    /// (the split could not be mirrored); empty when the segment is on no periodic surface.
    fn images(&self, a: u32, b: u32) -> Option<Vec<(u32, u32)>> {
        let look =
            |m: &[(u32, u32)], x: u32| m.binary_search_by_key(&x, |p| p.0).ok().map(|i| m[i].1);
        let mut seen = vec![(a.min(b), a.max(b))];
        let mut head = 0;
        while head < seen.len() {
            let (x, y) = seen[head];
            head += 1;
            let k = edge_key(x, y);
            for (s, m, fwd, back) in &self.links {
                for (from, to, map) in [(*s, *m, fwd), (*m, *s, back)] {
                    if !self.on(k, from) {
                        continue;
                    }
                    let (x2, y2) = (look(map, x)?, look(map, y)?);
                    if !self.on(edge_key(x2, y2), to) {
                        return None;
                    }
                    let e = (x2.min(y2), x2.max(y2));
                    if !seen.contains(&e) {
                        seen.push(e);
                    }
                }
            }
        }
        Some(seen.split_off(1))
    }
}

/// For every wall segment bordered by quads (`blocked`), the quad chord through it: the
/// edges reached by repeatedly stepping from an edge to the opposite edge of each quad
/// holding it. Splitting all of them at their midpoints splits each quad of the chord into
/// two quads and keeps the mesh conforming; the triangles on the chord's end edges are split
/// like any parity split. Chords where a quad would be crossed both ways, that touch a
/// periodic curve, or that are longer than 10⁵ edges are left out. Each chord is returned
/// once, as `(a, b, curve)` edges starting with its wall segment.
fn quad_chords(
    mesh: &Mesh,
    nodes: &NodeTable,
    walls: &[(u64, u32, bool)],
    blocked: &[u64],
    wall_curve: &dyn Fn(u64) -> Option<i32>,
    curve_of: &dyn Fn(u64) -> Option<i32>,
    periodic: &PeriodicCurves,
) -> Vec<Vec<(u32, u32, Option<i32>)>> {
    // (edge key, quad index, position of the edge in the quad)
    let mut quads: Vec<[u32; 4]> = Vec::new();
    for b in &mesh.element_blocks {
        if b.entity_dim != 2 || b.element_type != etype::QUAD4 {
            continue;
        }
        for i in 0..b.len() {
            let e = b.element(i);
            let ids: Vec<u32> = e.iter().filter_map(|&t| nodes.id(t)).collect();
            if let [p, q, r, s] = ids[..] {
                quads.push([p, q, r, s]);
            }
        }
    }
    let mut by_edge: Vec<(u64, u32, u8)> = Vec::with_capacity(4 * quads.len());
    for (qi, q) in quads.iter().enumerate() {
        for j in 0..4 {
            by_edge.push((edge_key(q[j], q[(j + 1) % 4]), qi as u32, j as u8));
        }
    }
    by_edge.sort_unstable();
    let mut starts: Vec<u64> = walls
        .iter()
        .map(|w| w.0)
        .filter(|k| blocked.binary_search(k).is_ok())
        .collect();
    starts.dedup();
    let mut done: std::collections::HashSet<u64> = std::collections::HashSet::new();
    let mut out = Vec::new();
    let mut dir: HashMap<u32, u8> = HashMap::new();
    let mut in_chord: std::collections::HashSet<u64> = std::collections::HashSet::new();
    'chord: for &start in &starts {
        if done.contains(&start) {
            continue;
        }
        dir.clear();
        in_chord.clear();
        in_chord.insert(start);
        let mut edges = vec![start];
        let mut head = 0;
        while head < edges.len() {
            let key = edges[head];
            head += 1;
            let lo = by_edge.partition_point(|x| x.0 < key);
            for &(_, qi, j) in by_edge[lo..].iter().take_while(|x| x.0 == key) {
                let axis = j % 2;
                match dir.get(&qi) {
                    Some(&d) if d == axis => continue,
                    Some(_) => continue 'chord,
                    None => {}
                }
                dir.insert(qi, axis);
                let q = quads[qi as usize];
                let o = (j as usize + 2) % 4;
                let opp = edge_key(q[o], q[(o + 1) % 4]);
                if in_chord.insert(opp) {
                    edges.push(opp);
                }
                if edges.len() > 100_000 {
                    continue 'chord;
                }
            }
        }
        let mut chord = Vec::with_capacity(edges.len());
        for &k in &edges {
            let is_wall = walls.binary_search_by_key(&k, |w| w.0).is_ok();
            let c = if is_wall { wall_curve(k) } else { curve_of(k) };
            if c.is_some_and(|c| periodic.has(c)) {
                continue 'chord;
            }
            chord.push(((k >> 32) as u32, k as u32, c));
        }
        done.extend(edges.iter().copied());
        out.push(chord);
    }
    out
}

/// Adds to every `$Periodic` link the pairs of new nodes whose segments it pairs: when a
/// link maps the ends of one split segment onto the ends of another split of the same
/// choice, the midpoints are paired too (curve links, and surface links, which list their
/// boundary nodes as well).
fn link_periodic_splits(mesh: &mut Mesh, split_sets: &[Vec<((u64, u64), u64)>]) {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unsolvable_message_is_plain_words() {
        let o = OddRegion {
            surface: 2,
            region: (0, 1),
            triangles: 117,
        };
        let p = OddRegion {
            surface: 5,
            region: (1, 3),
            triangles: 9,
        };
        let msg = unsolvable_message(&[o.clone(), p], &[true, false]);
        assert!(msg.contains("surface 2 has 117 triangles (odd)"), "{msg}");
        assert!(msg.contains("surface 5 (region 2 of 3"), "{msg}");
        assert!(!msg.contains('{') && !msg.contains("OddRegion"), "{msg}");
        let e = still_odd_error(&[o]).to_string();
        assert!(!e.contains('{') && e.contains("surface 2 has 117"), "{e}");
    }

    #[test]
    fn gf2_solve_handles_three_way_columns() {
        // rows: 3 components; columns flip {0,1,2} and {0,1}: only their sum flips {2}
        let cols = vec![vec![0, 1, 2], vec![0, 1]];
        let flips = |x: &[bool]| {
            let mut got = [false; 3];
            for (j, c) in cols.iter().enumerate() {
                if x[j] {
                    for &r in c {
                        got[r as usize] ^= true;
                    }
                }
            }
            got
        };
        assert_eq!(
            flips(&gf2_solve(3, &cols, &[false, false, true])),
            [false, false, true]
        );
        assert_eq!(
            flips(&gf2_solve(3, &cols, &[true, true, false])),
            [true, true, false]
        );
        // {0} alone is out of reach: whatever is returned leaves some row wrong
        assert_ne!(
            flips(&gf2_solve(3, &cols, &[true, false, false])),
            [true, false, false]
        );
    }
}
