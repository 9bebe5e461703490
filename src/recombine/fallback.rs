//! The fallback that always gives valid quads where pairing triangles cannot: chosen
//! triangles are split into three quads each (centroid and edge midpoints, the refinement
//! rule of Figure 2 applied locally), before the matching runs on what is left. A chosen
//! flat pair ([`FlatPair`]: two triangles whose quad is flat or reflex at an end of their
//! shared edge) becomes three quads with its two edges away from that node split, so the
//! edges at the node (on a boundary, its curve's segments and what lies beyond them) stay
//! whole. Chosen boundary segments are split at their midpoints too, as a parity repair's
//! split is: the triangles on them become two each. Chosen peel edges (the radial edges of
//! a boundary fan) are split at their midpoints, and a triangle whose only split edges are
//! two of them is peeled: a quad on its third edge and a triangle at the node between the
//! two split edges, which the matching pairs.
//!
//! Splitting a triangle's edge at its midpoint also splits the element on the other side of
//! that edge, whatever surface it belongs to, so the mesh stays conforming:
//! - a triangle that would get two or three split edges joins the chosen set (its third edge
//!   is split too), until no other triangle has more than one, unless its two split edges
//!   are peel edges (it is peeled);
//! - a triangle with one split edge becomes two triangles (as a parity split does);
//! - a 2-node line element on a split edge becomes two lines;
//! - a quad (already in the file) with a split edge gets its opposite edge split too, so the
//!   split runs along its quad strip until it reaches a triangle or a boundary; such a quad
//!   becomes two quads (or four around its centre when both pairs of opposite edges are
//!   split).
//!
//! A split on either side of a `$Periodic` link (curves or surfaces) is mirrored on the
//! other: the image of a chosen triangle is chosen, the image of a split edge is split, and
//! the new nodes are paired in the link, so a slave stays the image of its master.
//!
//! Every child of a split triangle is a convex quad (a corner of the triangle, two edge
//! midpoints and the centroid), oriented like its parent; a flat pair's children meet at
//! the midpoint of its shared edge (on the input surface, on both of its triangles) and are
//! oriented like its triangles; a peeled triangle's quad (its third edge's ends and the two
//! midpoints) is a convex trapezoid and its triangle a half-size copy at the node, both
//! oriented like it; edge midpoints are chord
//! midpoints, so planar areas and straight curves are unchanged. New edge nodes are
//! classified like parity-split nodes: on the edge's curve (line element or node
//! classification), else on the surface of the first triangle holding the edge; centroids on
//! their triangle's surface. The first child of an element keeps its tag; the others and the
//! new nodes get tags above the maximum.

use std::collections::{BTreeMap, HashMap, HashSet};

use glam::DVec3;

use crate::mesh::{etype, ElementBlock, Mesh, NodeBlock};

/// What the fallback's triangle splits did.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize)]
pub struct FallbackSplit {
    /// Triangles split into three quads (the chosen ones and those added to keep every
    /// other triangle at one split edge at most).
    pub triangles_to_quads: usize,
    /// Flat pairs split into three quads: two adjacent triangles whose quad is flat or
    /// reflex at an end of their shared edge.
    pub pairs_split: usize,
    /// Neighbouring triangles split in two.
    pub triangles_halved: usize,
    /// Quads already in the file that were split (into two quads across a strip, or four).
    pub quads_split: usize,
    /// Line elements split in two.
    pub lines_split: usize,
    /// Chosen segments split at their midpoints.
    pub segments_split: usize,
    /// Triangles peeled: two of their edges, both chosen peel edges, split at their
    /// midpoints, the triangle cut into a quad on its third edge and a triangle at the
    /// node between the split edges.
    pub triangles_peeled: usize,
    /// The midpoints of the peeled triangles' split edges (sorted tags): inside their
    /// surface, placed by the optimizer.
    #[serde(skip)]
    pub peel_nodes: Vec<u64>,
    /// Surfaces with peeled triangles (sorted).
    pub peeled_surfaces: Vec<i32>,
    /// New nodes.
    pub nodes_added: usize,
    /// Surfaces whose triangles were split into quads.
    pub surfaces: Vec<i32>,
}

/// A new node: tag, classifying entity (dim, tag), position, parent nodes (for parametric
/// coordinates).
type NewNode = (u64, (i32, i32), DVec3, Vec<u64>);

fn key(a: u64, b: u64) -> (u64, u64) {
    (a.min(b), a.max(b))
}

/// Appends the quads `children` of element `i` of block `b` (a triangle) to the quad block
/// of its surface in `quads_of`, the first with the element's tag when `keep_tag` and the
/// others with `fresh` ones, each with the element's partitions.
fn push_children(
    quads_of: &mut BTreeMap<i32, ElementBlock>,
    b: &ElementBlock,
    i: usize,
    children: &[[u64; 4]],
    keep_tag: bool,
    fresh: &mut impl FnMut() -> u64,
) {
    let part = b.partitions.as_ref().and_then(|p| p.get(i).cloned());
    let q = quads_of
        .entry(b.entity_tag)
        .or_insert_with(|| ElementBlock {
            entity_dim: 2,
            entity_tag: b.entity_tag,
            element_type: etype::QUAD4,
            tags: Vec::new(),
            nodes: Vec::new(),
            partitions: b.partitions.as_ref().map(|_| Vec::new()),
        });
    for (j, child) in children.iter().enumerate() {
        q.tags.push(if j == 0 && keep_tag { b.tags[i] } else { fresh() });
        q.nodes.extend_from_slice(child);
        if let Some(p) = q.partitions.as_mut() {
            p.push(part.clone().unwrap_or_default());
        }
    }
}

/// The polygon `[a, b, c, x]` of two triangles `t` and `u` (node tags, same orientation)
/// sharing the edge `b-x` at `b` = `node`, oriented like them, and whether `t` is the one
/// holding `a` (the one where `x` follows `b`); None when they share no such edge.
fn pair_corners(t: &[u64], u: &[u64], node: u64) -> Option<(bool, [u64; 4])> {
    let after = |tri: &[u64], n: u64| tri.iter().position(|&v| v == n).map(|i| tri[(i + 1) % 3]);
    let other = |tri: &[u64], n: u64, m: u64| tri.iter().copied().find(|&v| v != n && v != m);
    // the triangle where x follows b is (a, b, x); in the other, b follows x: (b, c, x)
    let (first, second, t_first) = match (after(t, node), after(u, node)) {
        (Some(x), Some(y)) if after(u, x) == Some(node) && y != x => (t, u, true),
        (Some(y), Some(x)) if after(t, x) == Some(node) && y != x => (u, t, false),
        _ => return None,
    };
    let x = after(first, node)?;
    let a = other(first, node, x)?;
    let c = other(second, node, x)?;
    (a != c).then_some((t_first, [a, node, c, x]))
}

/// Two adjacent triangles of one surface (element tags) whose quad is flat or reflex at
/// `node`, an end of their shared edge, split by [`split_triangles`] into three quads:
/// with the pair as the polygon `a, b, c, x` (`b` = `node`, `b-x` the shared edge), the
/// two edges away from `b` (`c-x`, `x-a`) are split at their midpoints `m2`, `m1` and a
/// centre `p` (the midpoint of `b-x`) joins them: `a, b, p, m1`, `b, c, m2, p` and
/// `p, m2, x, m1`. The corner at `b` is shared by two quads, and the edges at `b` (on a
/// boundary, the curve's segments) stay whole, so the elements beyond them are not
/// touched.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct FlatPair {
    /// The element tags of the two triangles.
    pub triangles: [u64; 2],
    /// The node of their shared edge where their quad is flat or reflex.
    pub node: u64,
}

/// One [`FlatPair`] being split: its two faces (`t1` holds `a`, `t2` holds `c`), its
/// polygon `[a, b, c, x]`, and whether it still splits as a pair (a split edge other than
/// its two far edges, or one of its triangles chosen, makes both triangles chosen).
struct PairSplit {
    faces: [u32; 2],
    corners: [u64; 4],
    live: bool,
}

impl PairSplit {
    /// The two edges away from `b`: `x-a` and `c-x`.
    fn far_edges(&self) -> [(u64, u64); 2] {
        let [a, _, c, x] = self.corners;
        [key(x, a), key(c, x)]
    }
}

/// Splits the 3-node triangles whose element tags are in `chosen` (and the ones the rule of
/// the module doc adds) into three quads each, the [`FlatPair`]s `pairs` into three quads
/// each, and the edges `segments` (node tags, either order) at their midpoints. Tags that
/// are not triangles are ignored, and so are segments that no element has. Triangles naming
/// a missing node are left alone. A pair whose tags are not two triangles of one surface
/// sharing an edge at its node, one of whose triangles is chosen or gets another split edge
/// (from the splits around it), or with an image through a `$Periodic` link (of either
/// triangle or of an edge it splits), has its two triangles split into three quads each
/// instead. The edges `peels` (node tags, either order; those no element has are skipped)
/// are split at their midpoints too, and a triangle whose only split edges are two of them
/// (or their images through a periodic link) is peeled: a quad on its third edge (its two
/// ends and the two midpoints) and a triangle at the node the two split edges share, both
/// oriented like it, the triangle keeping its tag.
pub fn split_triangles(
    mesh: &mut Mesh,
    chosen: &HashSet<u64>,
    pairs: &[FlatPair],
    segments: &[(u64, u64)],
    peels: &[(u64, u64)],
) -> FallbackSplit {
    let mut report = FallbackSplit::default();
    let index = mesh.node_index();
    let pos = |t: u64| -> Option<DVec3> {
        index
            .get(t)
            .map(|r| DVec3::from_array(mesh.node_blocks[r.block as usize].coords[r.index as usize]))
    };
    // every triangle and quad, as (block, element), and the faces at each edge
    let mut faces: Vec<(usize, usize)> = Vec::new();
    let mut at_edge: Vec<((u64, u64), u32)> = Vec::new();
    let mut marked: Vec<bool> = Vec::new();
    for (bi, b) in mesh.element_blocks.iter().enumerate() {
        if !b.is_linear_face() {
            continue;
        }
        let k = b.nodes_per_element();
        for i in 0..b.len() {
            let e = b.element(i);
            if e.iter().any(|&t| pos(t).is_none()) {
                continue;
            }
            let id = faces.len() as u32;
            faces.push((bi, i));
            marked.push(k == 3 && chosen.contains(&b.tags[i]));
            for j in 0..k {
                at_edge.push((key(e[j], e[(j + 1) % k]), id));
            }
        }
    }
    // speed: one sorted list, not a map of lists (the faces of an edge by increasing id),
    // counting-sorted by the edge's first node
    if !crate::keysort::bucket_sort(&mut at_edge, |x| x.0 .0) {
        at_edge.sort_unstable();
    }
    let faces_at = |e: (u64, u64)| -> &[((u64, u64), u32)] {
        let from = at_edge.partition_point(|x| x.0 < e);
        let to = from + at_edge[from..].partition_point(|x| x.0 == e);
        &at_edge[from..to]
    };
    let face_nodes = |id: u32| -> &[u64] {
        let (bi, i) = faces[id as usize];
        mesh.element_blocks[bi].element(i)
    };
    // the flat pairs: their faces and polygons, or their triangles chosen
    let mut pair_splits: Vec<PairSplit> = Vec::new();
    let mut pair_of: HashMap<u32, usize> = HashMap::new();
    if !pairs.is_empty() {
        let wanted: HashSet<u64> = pairs.iter().flat_map(|p| p.triangles).collect();
        let face_of: HashMap<u64, u32> = (0..faces.len() as u32)
            .filter(|&id| {
                let (bi, i) = faces[id as usize];
                let b = &mesh.element_blocks[bi];
                b.nodes_per_element() == 3 && wanted.contains(&b.tags[i])
            })
            .map(|id| {
                let (bi, i) = faces[id as usize];
                (mesh.element_blocks[bi].tags[i], id)
            })
            .collect();
        for p in pairs {
            let (Some(&f1), Some(&f2)) = (face_of.get(&p.triangles[0]), face_of.get(&p.triangles[1]))
            else {
                continue;
            };
            let corners = pair_corners(face_nodes(f1), face_nodes(f2), p.node);
            let surface = |f: u32| {
                let b = &mesh.element_blocks[faces[f as usize].0];
                (b.entity_dim, b.entity_tag)
            };
            let taken = |f: u32| marked[f as usize] || pair_of.contains_key(&f);
            match corners {
                Some((first, corners))
                    if f1 != f2 && surface(f1) == surface(f2) && !taken(f1) && !taken(f2) =>
                {
                    let faces = if first { [f1, f2] } else { [f2, f1] };
                    pair_of.insert(f1, pair_splits.len());
                    pair_of.insert(f2, pair_splits.len());
                    pair_splits.push(PairSplit {
                        faces,
                        corners,
                        live: true,
                    });
                }
                _ => {
                    for f in [f1, f2] {
                        if !pair_of.contains_key(&f) {
                            marked[f as usize] = true;
                        }
                    }
                }
            }
        }
    }
    // `$Periodic` links of curves and surfaces, both ways (slave -> master, master ->
    // slave): a split on one side is mirrored on the other, so the slave stays the image
    // of its master
    let links: Vec<[HashMap<u64, u64>; 2]> = mesh
        .periodic
        .iter()
        .filter(|l| l.dim == 1 || l.dim == 2)
        .map(|l| {
            [
                l.node_pairs.iter().copied().collect(),
                l.node_pairs.iter().map(|&(a, b)| (b, a)).collect(),
            ]
        })
        .collect();
    let tri_of: HashMap<[u64; 3], u32> = if links.is_empty() {
        HashMap::new()
    } else {
        (0..faces.len() as u32)
            .filter(|&id| face_nodes(id).len() == 3)
            .map(|id| {
                let n = face_nodes(id);
                let mut k = [n[0], n[1], n[2]];
                k.sort_unstable();
                (k, id)
            })
            .collect()
    };
    let edge_images = |e: (u64, u64)| -> Vec<(u64, u64)> {
        let mut out = Vec::new();
        for map in links.iter().flatten() {
            if let (Some(&x), Some(&y)) = (map.get(&e.0), map.get(&e.1)) {
                if !faces_at(key(x, y)).is_empty() {
                    out.push(key(x, y));
                }
            }
        }
        out
    };
    let tri_images = |n: &[u64]| -> Vec<u32> {
        let mut out = Vec::new();
        for map in links.iter().flatten() {
            let img: Option<Vec<u64>> = n.iter().map(|t| map.get(t).copied()).collect();
            if let Some(img) = img {
                let mut k = [img[0], img[1], img[2]];
                k.sort_unstable();
                if let Some(&id) = tri_of.get(&k) {
                    out.push(id);
                }
            }
        }
        out
    };
    // close the split edges: no triangle outside the chosen set keeps two of them, a quad
    // with one gets its opposite one too (the split runs along the quad strip), and the
    // image of a chosen triangle or of a split edge through a periodic link is chosen or
    // split too
    let mut split: HashSet<(u64, u64)> = HashSet::new();
    let mut work: Vec<(u64, u64)> = Vec::new();
    let mut tris: Vec<u32> = (0..marked.len() as u32)
        .filter(|&t| marked[t as usize])
        .collect();
    for &(a, b) in segments {
        if !faces_at(key(a, b)).is_empty() && !work.contains(&key(a, b)) {
            work.push(key(a, b));
            report.segments_split += 1;
        }
    }
    // the peel edges and their images through periodic links (mirrored like every split)
    let mut peel: HashSet<(u64, u64)> = HashSet::new();
    for &(a, b) in peels {
        let e = key(a, b);
        if faces_at(e).is_empty() || !peel.insert(e) {
            continue;
        }
        work.push(e);
        peel.extend(edge_images(e));
    }
    // a pair with an image through a periodic link (of a triangle or of a far edge) is
    // split as chosen triangles, which are mirrored
    for p in pair_splits.iter_mut() {
        let mirrored = p.faces.iter().any(|&f| !tri_images(face_nodes(f)).is_empty())
            || p.far_edges().iter().any(|&e| !edge_images(e).is_empty());
        if mirrored {
            p.live = false;
            for f in p.faces {
                marked[f as usize] = true;
                tris.push(f);
            }
        } else {
            work.extend(p.far_edges());
        }
    }
    loop {
        while let Some(t) = tris.pop() {
            let n = face_nodes(t);
            work.extend((0..3).map(|j| key(n[j], n[(j + 1) % 3])));
            for img in tri_images(n) {
                if !marked[img as usize] {
                    marked[img as usize] = true;
                    tris.push(img);
                }
            }
        }
        let Some(e) = work.pop() else { break };
        if !split.insert(e) {
            continue;
        }
        work.extend(edge_images(e));
        for &(_, o) in faces_at(e) {
            let on = face_nodes(o);
            if on.len() == 4 {
                let j = (0..4)
                    .find(|&j| key(on[j], on[(j + 1) % 4]) == e)
                    .unwrap_or(0);
                work.push(key(on[(j + 2) % 4], on[(j + 3) % 4]));
                continue;
            }
            if marked[o as usize] {
                continue;
            }
            if let Some(&k) = pair_of.get(&o) {
                let p = &mut pair_splits[k];
                if p.live && !p.far_edges().contains(&e) {
                    // another split edge: the pair's triangles are split as chosen ones
                    p.live = false;
                    for f in p.faces {
                        marked[f as usize] = true;
                        tris.push(f);
                    }
                }
                if p.live || marked[o as usize] {
                    continue;
                }
            }
            let edges = [0, 1, 2].map(|k| key(on[k], on[(k + 1) % 3]));
            let cut = edges.iter().filter(|x| split.contains(x)).count();
            let peeled = cut == 2
                && edges
                    .iter()
                    .filter(|x| split.contains(x))
                    .all(|x| peel.contains(x));
            if cut >= 3 || (cut == 2 && !peeled) {
                marked[o as usize] = true;
                tris.push(o);
            }
        }
    }
    if split.is_empty() {
        return report;
    }

    // where each new edge node lives: a line element's curve, a classified curve, or the
    // surface of the first triangle holding the edge
    let mut owner: BTreeMap<(u64, u64), (i32, i32)> = BTreeMap::new();
    for b in &mesh.element_blocks {
        if b.element_type != etype::LINE2 {
            continue;
        }
        for i in 0..b.len() {
            let e = b.element(i);
            let k = key(e[0], e[1]);
            if split.contains(&k) {
                owner.entry(k).or_insert((1, b.entity_tag));
            }
        }
    }
    let lined = crate::mesh::lined_curves(mesh);
    let mut edges: Vec<(u64, u64)> = split.iter().copied().collect();
    edges.sort_unstable();
    for &e in &edges {
        if owner.contains_key(&e) {
            continue;
        }
        let o = match crate::mesh::classified_curve(mesh, &index, &lined, e.0, e.1) {
            Some(c) => (1, c),
            None => {
                let first = faces_at(e).first().map(|x| x.1);
                let s = first.map_or(0, |t| mesh.element_blocks[faces[t as usize].0].entity_tag);
                (2, s)
            }
        };
        owner.insert(e, o);
    }
    let mut next_node = mesh.max_node_tag() + 1;
    let mut new_nodes: Vec<NewNode> = Vec::new();
    let mut mid: HashMap<(u64, u64), u64> = HashMap::new();
    for &e in &edges {
        let (Some(a), Some(b)) = (pos(e.0), pos(e.1)) else {
            continue;
        };
        let o = owner.get(&e).copied().unwrap_or((2, 0));
        new_nodes.push((next_node, o, 0.5 * (a + b), vec![e.0, e.1]));
        mid.insert(e, next_node);
        next_node += 1;
    }
    let midpoint = |a: u64, b: u64| mid.get(&key(a, b)).copied();
    // each live pair's centre, and its faces by (block, element) with their role
    let mut pair_at: HashMap<(usize, usize), (usize, usize)> = HashMap::new();
    let mut centres: Vec<u64> = vec![0; pair_splits.len()];
    for (k, p) in pair_splits.iter().enumerate().filter(|(_, p)| p.live) {
        let [_, b, _, x] = p.corners;
        let (Some(pb), Some(px)) = (pos(b), pos(x)) else {
            continue;
        };
        let (bi, _) = faces[p.faces[0] as usize];
        let surface = mesh.element_blocks[bi].entity_tag;
        new_nodes.push((next_node, (2, surface), 0.5 * (pb + px), vec![b, x]));
        centres[k] = next_node;
        next_node += 1;
        for (role, &f) in p.faces.iter().enumerate() {
            pair_at.insert(faces[f as usize], (k, role));
        }
    }

    // rewrite the element blocks
    let mut next_elem = mesh.max_element_tag() + 1;
    let mut fresh = || {
        next_elem += 1;
        next_elem - 1
    };
    let mut quads_of: BTreeMap<i32, ElementBlock> = BTreeMap::new();
    let mut tri_marked: Vec<Vec<bool>> = mesh
        .element_blocks
        .iter()
        .map(|b| {
            vec![
                false;
                if b.element_type == etype::TRI3 {
                    b.len()
                } else {
                    0
                }
            ]
        })
        .collect();
    for (id, &(bi, i)) in faces.iter().enumerate() {
        if let Some(m) = tri_marked[bi].get_mut(i) {
            *m = marked[id];
        }
    }
    let mut blocks: Vec<ElementBlock> = Vec::with_capacity(mesh.element_blocks.len() + 1);
    for (bi, b) in mesh.element_blocks.iter().enumerate() {
        let handled = matches!(b.element_type, etype::TRI3 | etype::LINE2 | etype::QUAD4);
        if !handled {
            blocks.push(b.clone());
            continue;
        }
        let mut out = ElementBlock {
            entity_dim: b.entity_dim,
            entity_tag: b.entity_tag,
            element_type: b.element_type,
            tags: Vec::with_capacity(b.len()),
            nodes: Vec::with_capacity(b.nodes.len()),
            partitions: b.partitions.as_ref().map(|_| Vec::new()),
        };
        for i in 0..b.len() {
            let e = b.element(i);
            let part = b.partitions.as_ref().and_then(|p| p.get(i).cloned());
            let push = |out: &mut ElementBlock, tag: u64, nodes: &[u64]| {
                out.tags.push(tag);
                out.nodes.extend_from_slice(nodes);
                if let Some(p) = out.partitions.as_mut() {
                    p.push(part.clone().unwrap_or_default());
                }
            };
            match b.element_type {
                etype::TRI3 if pair_at.contains_key(&(bi, i)) => {
                    let Some(&(k, role)) = pair_at.get(&(bi, i)) else {
                        continue;
                    };
                    let [a, b_, c, x] = pair_splits[k].corners;
                    let p = centres[k];
                    let (Some(m1), Some(m2)) = (midpoint(x, a), midpoint(c, x)) else {
                        push(&mut out, b.tags[i], e);
                        continue;
                    };
                    let children: &[[u64; 4]] = if role == 0 {
                        &[[a, b_, p, m1], [p, m2, x, m1]]
                    } else {
                        &[[b_, c, m2, p]]
                    };
                    push_children(&mut quads_of, b, i, children, true, &mut fresh);
                    if role == 0 {
                        report.pairs_split += 1;
                    }
                    if !report.surfaces.contains(&b.entity_tag) {
                        report.surfaces.push(b.entity_tag);
                    }
                }
                etype::TRI3 if tri_marked[bi].get(i).copied().unwrap_or(false) => {
                    let (Some(m), Some(c)) = (
                        (0..3)
                            .map(|j| midpoint(e[j], e[(j + 1) % 3]))
                            .collect::<Option<Vec<u64>>>(),
                        e.iter().map(|&t| pos(t)).sum::<Option<DVec3>>(),
                    ) else {
                        push(&mut out, b.tags[i], e);
                        continue;
                    };
                    let centre = next_node;
                    next_node += 1;
                    new_nodes.push((centre, (2, b.entity_tag), c / 3.0, e.to_vec()));
                    let children = [0, 1, 2].map(|j| [e[j], m[j], centre, m[(j + 2) % 3]]);
                    push_children(&mut quads_of, b, i, &children, true, &mut fresh);
                    report.triangles_to_quads += 1;
                    if !report.surfaces.contains(&b.entity_tag) {
                        report.surfaces.push(b.entity_tag);
                    }
                }
                etype::TRI3 => {
                    // the closure leaves a triangle outside the chosen set none, one (it is
                    // halved) or two split edges (two peel edges: it is peeled)
                    let m = [0, 1, 2].map(|j| midpoint(e[j], e[(j + 1) % 3]));
                    let corners = |j: usize| (e[j], e[(j + 1) % 3], e[(j + 2) % 3]);
                    match m.iter().flatten().count() {
                        0 => push(&mut out, b.tags[i], e),
                        2 => {
                            // edge x-y whole, z the node between the split edges
                            let j = m.iter().position(Option::is_none).unwrap_or(0);
                            let (x, y, z) = corners(j);
                            let (Some(myz), Some(mzx)) = (m[(j + 1) % 3], m[(j + 2) % 3]) else {
                                push(&mut out, b.tags[i], e);
                                continue;
                            };
                            push(&mut out, b.tags[i], &[mzx, myz, z]);
                            push_children(&mut quads_of, b, i, &[[x, y, myz, mzx]], false, &mut fresh);
                            report.triangles_peeled += 1;
                            report.peel_nodes.extend([myz, mzx]);
                            if !report.peeled_surfaces.contains(&b.entity_tag) {
                                report.peeled_surfaces.push(b.entity_tag);
                            }
                            if !report.surfaces.contains(&b.entity_tag) {
                                report.surfaces.push(b.entity_tag);
                            }
                        }
                        _ => {
                            let j = m.iter().position(Option::is_some).unwrap_or(0);
                            let (x, y, z) = corners(j);
                            let Some(mid) = m[j] else {
                                push(&mut out, b.tags[i], e);
                                continue;
                            };
                            push(&mut out, b.tags[i], &[x, mid, z]);
                            push(&mut out, fresh(), &[mid, y, z]);
                            report.triangles_halved += 1;
                        }
                    }
                }
                etype::LINE2 => match midpoint(e[0], e[1]) {
                    Some(m) => {
                        push(&mut out, b.tags[i], &[e[0], m]);
                        push(&mut out, fresh(), &[m, e[1]]);
                        report.lines_split += 1;
                    }
                    None => push(&mut out, b.tags[i], e),
                },
                _ => {
                    // a quad: none, two opposite or all four edges split (the closure)
                    let m = [0, 1, 2, 3].map(|j| midpoint(e[j], e[(j + 1) % 4]));
                    match m {
                        [None, None, None, None] => push(&mut out, b.tags[i], e),
                        [Some(m0), Some(m1), Some(m2), Some(m3)] => {
                            let Some(c) = e.iter().map(|&t| pos(t)).sum::<Option<DVec3>>() else {
                                push(&mut out, b.tags[i], e);
                                continue;
                            };
                            let centre = next_node;
                            next_node += 1;
                            new_nodes.push((centre, (2, b.entity_tag), c / 4.0, e.to_vec()));
                            let mm = [m0, m1, m2, m3];
                            for j in 0..4 {
                                let tag = if j == 0 { b.tags[i] } else { fresh() };
                                push(&mut out, tag, &[e[j], mm[j], centre, mm[(j + 3) % 4]]);
                            }
                            report.quads_split += 1;
                        }
                        _ => {
                            // edges j and j + 2 split: two quads across the strip
                            let j = (0..4).find(|&j| m[j].is_some()).unwrap_or(0);
                            let (Some(a), Some(c)) = (m[j], m[(j + 2) % 4]) else {
                                push(&mut out, b.tags[i], e);
                                continue;
                            };
                            let r = |o: usize| e[(j + o) % 4];
                            push(&mut out, b.tags[i], &[r(0), a, c, r(3)]);
                            push(&mut out, fresh(), &[a, r(1), r(2), c]);
                            report.quads_split += 1;
                        }
                    }
                }
            }
        }
        blocks.push(out);
    }
    // the new quads join the surface's quad block (the first one), or follow its triangles
    for (s, q) in quads_of {
        let at_quads = blocks
            .iter()
            .position(|b| b.entity_dim == 2 && b.entity_tag == s && b.element_type == etype::QUAD4);
        match at_quads {
            Some(i) => {
                let b = &mut blocks[i];
                b.tags.extend_from_slice(&q.tags);
                b.nodes.extend_from_slice(&q.nodes);
                match (b.partitions.as_mut(), q.partitions) {
                    (Some(p), Some(new)) => p.extend(new),
                    (Some(p), None) => p.extend(q.tags.iter().map(|_| Vec::new())),
                    (None, Some(new)) => {
                        let mut all = vec![Vec::new(); b.tags.len() - new.len()];
                        all.extend(new);
                        b.partitions = Some(all);
                    }
                    (None, None) => {}
                }
            }
            None => {
                let after = blocks
                    .iter()
                    .rposition(|b| {
                        b.entity_dim == 2 && b.entity_tag == s && b.element_type == etype::TRI3
                    })
                    .map_or(blocks.len(), |i| i + 1);
                blocks.insert(after, q);
            }
        }
    }
    blocks.retain(|b| !b.is_empty() || b.element_type != etype::TRI3);

    // the new nodes, into the blocks of their entities
    report.nodes_added = new_nodes.len();
    let mut block_of: HashMap<(i32, i32), usize> = HashMap::new();
    for (bi, b) in mesh.node_blocks.iter().enumerate() {
        block_of.entry((b.entity_dim, b.entity_tag)).or_insert(bi);
    }
    let mut node_blocks = mesh.node_blocks.clone();
    for (tag, o, p, parents) in &new_nodes {
        let bi = *block_of.entry(*o).or_insert_with(|| {
            node_blocks.push(NodeBlock {
                entity_dim: o.0,
                entity_tag: o.1,
                tags: Vec::new(),
                coords: Vec::new(),
                params: None,
            });
            node_blocks.len() - 1
        });
        let np = o.0.max(0) as usize;
        let has_params = node_blocks[bi].params.is_some();
        let uv = if has_params {
            crate::mesh::mean_params(&mesh.node_blocks, &index, bi, np, parents).0
        } else {
            Vec::new()
        };
        let blk = &mut node_blocks[bi];
        blk.tags.push(*tag);
        blk.coords.push(p.to_array());
        if let Some(params) = blk.params.as_mut() {
            params.extend_from_slice(&uv);
        }
    }
    mesh.node_blocks = node_blocks;
    mesh.element_blocks = blocks;
    link_new_nodes(mesh, &new_nodes);
    mesh.invalidate_element_data();
    report.surfaces.sort_unstable();
    report.peeled_surfaces.sort_unstable();
    report.peel_nodes.sort_unstable();
    report.peel_nodes.dedup();
    report
}

/// Adds to every `$Periodic` link of curves and surfaces the pairs of new nodes whose
/// parents (the ends of a split edge, the corners of a split face) it pairs: the splits are
/// mirrored (see [`split_triangles`]), so a slave's new node has its master's counterpart.
fn link_new_nodes(mesh: &mut Mesh, new_nodes: &[NewNode]) {
    if mesh.periodic.is_empty() || new_nodes.is_empty() {
        return;
    }
    let sorted = |v: &[u64]| {
        let mut v = v.to_vec();
        v.sort_unstable();
        v
    };
    let by_parents: HashMap<Vec<u64>, u64> =
        new_nodes.iter().map(|n| (sorted(&n.3), n.0)).collect();
    for link in mesh
        .periodic
        .iter_mut()
        .filter(|l| l.dim == 1 || l.dim == 2)
    {
        let to_master: HashMap<u64, u64> = link.node_pairs.iter().copied().collect();
        let mut add = Vec::new();
        for (tag, _, _, parents) in new_nodes {
            let image: Option<Vec<u64>> =
                parents.iter().map(|p| to_master.get(p).copied()).collect();
            if let Some(&m) = image.and_then(|i| by_parents.get(&sorted(&i))) {
                if m != *tag {
                    add.push((*tag, m));
                }
            }
        }
        link.node_pairs.extend(add);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Entity;

    /// Two surfaces sharing the curve 2-3: surface 1 = triangles (1 2 3), (1 3 4);
    /// surface 2 = triangle (2 5 3); the curve 2-3 has a line element.
    fn two_surfaces() -> Mesh {
        let mut m = Mesh::default();
        for (dim, tag) in [(1, 7), (2, 1), (2, 2)] {
            m.entities[dim as usize].push(Entity {
                dim,
                tag,
                bbox: [0.0; 6],
                physical_tags: Vec::new(),
                bounding: Vec::new(),
            });
        }
        m.node_blocks.push(NodeBlock {
            entity_dim: 2,
            entity_tag: 1,
            tags: vec![1, 2, 3, 4, 5],
            coords: vec![
                [0., 0., 0.],
                [1., 0., 0.],
                [1., 1., 0.],
                [0., 1., 0.],
                [2., 0.5, 0.],
            ],
            params: None,
        });
        let block = |tag: i32, ty: u32, tags: Vec<u64>, nodes: Vec<u64>| ElementBlock {
            entity_dim: if ty == etype::LINE2 { 1 } else { 2 },
            entity_tag: tag,
            element_type: ty,
            tags,
            nodes,
            partitions: None,
        };
        m.element_blocks
            .push(block(7, etype::LINE2, vec![10], vec![2, 3]));
        m.element_blocks
            .push(block(1, etype::TRI3, vec![1, 2], vec![1, 2, 3, 1, 3, 4]));
        m.element_blocks
            .push(block(2, etype::TRI3, vec![3], vec![2, 5, 3]));
        m
    }

    #[test]
    fn a_chosen_segment_halves_the_triangles_on_both_sides_and_its_line() {
        let mut m = two_surfaces();
        // the curve segment 2-3 (either order); 1-5 is no edge and is ignored
        let r = split_triangles(&mut m, &HashSet::new(), &[], &[(3, 2), (1, 5)], &[]);
        assert_eq!(r.segments_split, 1);
        assert_eq!(r.triangles_to_quads, 0);
        assert_eq!(r.triangles_halved, 2);
        assert_eq!(r.lines_split, 1);
        assert_eq!(r.nodes_added, 1);
        let on_curve = m
            .node_blocks
            .iter()
            .find(|b| b.entity_dim == 1 && b.entity_tag == 7)
            .map(|b| (b.tags.clone(), b.coords.clone()));
        assert_eq!(on_curve, Some((vec![6], vec![[1.0, 0.5, 0.0]])));
        // surface 1: (1 2 3) halved at 6, (1 3 4) kept; surface 2: (2 5 3) halved
        let triangles = |s: i32| -> Vec<Vec<u64>> {
            let b = m
                .element_blocks
                .iter()
                .find(|b| b.entity_tag == s && b.element_type == etype::TRI3)
                .expect("triangles");
            (0..b.len()).map(|i| b.element(i).to_vec()).collect()
        };
        assert_eq!(triangles(1).len(), 3);
        assert_eq!(triangles(2).len(), 2);
        assert!(triangles(1)
            .iter()
            .chain(&triangles(2))
            .all(|t| !t.contains(&2) || !t.contains(&3)));
    }

    /// One planar surface: a fan of three triangles at apex 5 over the boundary nodes 1, 2,
    /// 3, 4 on the x axis, and a triangle (1 5 6) beyond its first radial edge.
    fn fan() -> Mesh {
        let coords = vec![
            [0., 0., 0.],
            [1., 0., 0.],
            [2., 0., 0.],
            [3., 0., 0.],
            [1.5, 2., 0.],
            [-1., 2., 0.],
        ];
        crate::mesh::testing::one_surface(
            vec![crate::mesh::testing::node_block(2, (1..=6).collect(), coords)],
            etype::TRI3,
            &[&[1, 2, 5], &[2, 3, 5], &[3, 4, 5], &[1, 5, 6]],
        )
    }

    #[test]
    fn a_triangle_with_two_peel_edges_becomes_a_quad_on_its_base_and_a_triangle_at_its_apex() {
        let mut m = fan();
        // the radial edges at the fan's two middle nodes (either order); 1-4 is no edge
        let r = split_triangles(&mut m, &HashSet::new(), &[], &[], &[(5, 2), (3, 5), (1, 4)]);
        assert_eq!(r.triangles_peeled, 1);
        assert_eq!(r.triangles_halved, 2, "the fan's end triangles");
        assert_eq!(r.triangles_to_quads, 0);
        assert_eq!(r.nodes_added, 2);
        assert_eq!(r.peel_nodes, vec![7, 8]);
        let mid = |a: u64| {
            let b = &m.node_blocks[0];
            let i = b.tags.iter().position(|&t| t == a).expect("node");
            b.coords[i]
        };
        assert_eq!(mid(7), [1.25, 1.0, 0.0], "the midpoint of 2-5");
        assert_eq!(mid(8), [1.75, 1.0, 0.0], "the midpoint of 3-5");
        let quads = m
            .element_blocks
            .iter()
            .find(|b| b.element_type == etype::QUAD4)
            .expect("quads");
        assert_eq!(quads.nodes, vec![2, 3, 8, 7], "on the base, oriented like the triangle");
        assert_ne!(quads.tags[0], 2, "the triangle keeps the tag");
        let tris = m
            .element_blocks
            .iter()
            .find(|b| b.element_type == etype::TRI3)
            .expect("triangles");
        let mut all: Vec<(u64, Vec<u64>)> =
            (0..tris.len()).map(|i| (tris.tags[i], tris.element(i).to_vec())).collect();
        all.sort();
        assert!(all.contains(&(2, vec![7, 8, 5])), "{all:?}");
        // every triangle and the quad keep the fan's orientation (counter-clockwise) and
        // no element holds a split edge whole
        let area = |n: &[u64]| {
            let p: Vec<[f64; 3]> = n.iter().map(|&t| mid(t)).collect();
            (0..n.len())
                .map(|k| {
                    let (a, b) = (p[k], p[(k + 1) % n.len()]);
                    a[0] * b[1] - b[0] * a[1]
                })
                .sum::<f64>()
        };
        for (_, t) in &all {
            assert!(area(t) > 0.0, "{t:?}");
            for e in [(2, 5), (3, 5)] {
                assert!(!(t.contains(&e.0) && t.contains(&e.1)), "{t:?} holds {e:?}");
            }
        }
        assert!(area(&quads.nodes) > 0.0);
        assert_eq!(all.len(), 2 * 2 + 1 + 1, "the fan's ends halved, the peeled one, and (1 5 6)");
    }

    #[test]
    fn a_triangle_with_a_peel_edge_and_another_split_edge_is_split_into_three_quads() {
        let mut m = fan();
        // 2-5 peeled, 3-5 split as a segment: the middle triangle is chosen
        let r = split_triangles(&mut m, &HashSet::new(), &[], &[(3, 5)], &[(2, 5)]);
        assert_eq!(r.triangles_peeled, 0);
        assert_eq!(r.triangles_to_quads, 1);
    }

    #[test]
    fn a_chosen_triangle_becomes_three_quads_and_its_neighbours_stay_conforming() {
        let mut m = two_surfaces();
        let r = split_triangles(&mut m, &HashSet::from([1]), &[], &[], &[]);
        // triangle 1 has split edges 1-2, 2-3, 3-1; triangle 2 (1 3 4) gets one (1-3) and
        // is halved; triangle 3 (2 5 3) gets one (2-3) and is halved; the line is split
        assert_eq!(r.triangles_to_quads, 1);
        assert_eq!(r.triangles_halved, 2);
        assert_eq!(r.lines_split, 1);
        assert_eq!(r.nodes_added, 4);
        let quads: Vec<&ElementBlock> = m
            .element_blocks
            .iter()
            .filter(|b| b.element_type == etype::QUAD4)
            .collect();
        assert_eq!(quads.len(), 1);
        assert_eq!(quads[0].len(), 3);
        assert_eq!(quads[0].tags[0], 1, "the first child keeps the tag");
        // the midpoint of the curve segment is on the curve
        let on_curve = m
            .node_blocks
            .iter()
            .find(|b| b.entity_dim == 1 && b.entity_tag == 7)
            .map(|b| b.coords.clone());
        assert_eq!(on_curve, Some(vec![[1.0, 0.5, 0.0]]));
        // conforming, oriented, boundaries split once, area kept: the recombination's own
        // invariant check (which allows triangles only through `--allow-triangles`-like
        // use, so compare the quads' validity and the rest separately)
        let before = two_surfaces();
        let msg = crate::recombine::check_invariants(&before, &m)
            .unwrap_err()
            .to_string();
        assert!(msg.contains("still has 2 triangles"), "{msg}");
        crate::optimize::check::check_surface_mesh(&{
            let mut lined = m.clone();
            lined
                .element_blocks
                .retain(|b| b.element_type != etype::LINE2);
            lined
        })
        .unwrap();
        // every new quad is valid about the input triangles
        assert!(crate::validity::invalid_quads(&before, &m).is_empty());
    }

    #[test]
    fn a_triangle_with_two_split_edges_joins_the_chosen_set() {
        let mut m = two_surfaces();
        // choosing both triangles of surface 1 splits all of their edges; the triangle of
        // surface 2 has one split edge (2-3) only
        let r = split_triangles(&mut m, &HashSet::from([1, 2]), &[], &[], &[]);
        assert_eq!(r.triangles_to_quads, 2);
        assert_eq!(r.triangles_halved, 1);
        let mut m = two_surfaces();
        // a square split on its diagonal: choosing (2 5 3) splits 2-3, which triangle 1 shares
        let r = split_triangles(&mut m, &HashSet::from([3]), &[], &[], &[]);
        assert_eq!((r.triangles_to_quads, r.triangles_halved), (1, 1));
        assert_eq!(r.surfaces, vec![2]);
    }

    #[test]
    fn a_flat_pair_becomes_three_quads_and_leaves_the_edges_at_its_node_whole() {
        let mut m = two_surfaces();
        // triangles 1 (1 2 3) and 2 (1 3 4) share 1-3; their quad is taken as flat at node
        // 3: the polygon 2, 3, 4, 1, split on 1-2 and 4-1 (no element beyond them)
        let pair = FlatPair {
            triangles: [2, 1],
            node: 3,
        };
        let r = split_triangles(&mut m, &HashSet::new(), &[pair], &[], &[]);
        assert_eq!(r.pairs_split, 1);
        assert_eq!(
            (r.triangles_to_quads, r.triangles_halved, r.lines_split),
            (0, 0, 0)
        );
        // two midpoints and the centre
        assert_eq!(r.nodes_added, 3);
        let quads: Vec<Vec<u64>> = m
            .element_blocks
            .iter()
            .filter(|b| b.element_type == etype::QUAD4)
            .flat_map(|b| (0..b.len()).map(move |i| b.element(i).to_vec()))
            .collect();
        assert_eq!(quads.len(), 3);
        // node 3 is a corner of two quads; the curve 2-3 and the edge 3-4 are edges of them
        assert_eq!(quads.iter().filter(|q| q.contains(&3)).count(), 2);
        let has_edge = |a: u64, b: u64| {
            quads
                .iter()
                .any(|q| (0..4).any(|j| key(q[j], q[(j + 1) % 4]) == key(a, b)))
        };
        assert!(has_edge(2, 3) && has_edge(3, 4));
        // surface 2 and the line are as they were; every quad is valid
        let before = two_surfaces();
        assert_eq!(m.element_blocks[0], before.element_blocks[0]);
        assert!(m
            .element_blocks
            .iter()
            .any(|b| b.entity_tag == 2 && b.element_type == etype::TRI3 && b.nodes == [2, 5, 3]));
        assert!(crate::validity::invalid_quads(&before, &m).is_empty());
    }

    #[test]
    fn a_flat_pair_with_another_split_edge_is_split_as_chosen_triangles() {
        // triangle 3 (2 5 3) chosen splits the curve 2-3, an edge at the pair's node
        let mut m = two_surfaces();
        let pair = FlatPair {
            triangles: [1, 2],
            node: 3,
        };
        let r = split_triangles(&mut m, &HashSet::from([3]), &[pair], &[], &[]);
        assert_eq!((r.pairs_split, r.triangles_to_quads), (0, 3));
        // a pair that is no pair at that node (node 2 is not on the shared edge 1-3)
        let mut m = two_surfaces();
        let pair = FlatPair {
            triangles: [1, 2],
            node: 2,
        };
        let r = split_triangles(&mut m, &HashSet::new(), &[pair], &[], &[]);
        assert_eq!((r.pairs_split, r.triangles_to_quads), (0, 2));
    }
}
