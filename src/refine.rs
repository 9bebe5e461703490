//! Uniform refinement (paper section 1 and Figure 2, after Borouchaki and Frey, ref. 3; the
//! rows `2h` and `4h` of Table I): every quad is split into four quads, every triangle into
//! three quads, every 2-node line into two lines. Meshing the triangles at `2h` (or `4h`),
//! recombining and refining once (twice) gives a mesh of size `h` whose new vertices are all
//! regular, at the price of a lower efficiency τ (Table I).
//!
//! # One level ([`refine`])
//! - **Edge nodes.** Every edge of a line, triangle or quad gets one new node, shared by all
//!   elements holding the edge, so the mesh stays conforming, across the curves that
//!   surfaces share too. An edge of a line element is classified on that line's curve; an
//!   edge whose two nodes are classified on the same curve without line elements (or on such
//!   a curve and a point bounding it) on that curve; any other edge on the first surface
//!   that holds it.
//! - **Where a curve node goes.** Without the CAD, the curve is estimated from its own nodes:
//!   the midpoint of segment `a b` is the four-point subdivision rule
//!   `9/16 (a + b) − 1/16 (p + q)` with `p`, `q` the curve nodes before `a` and after `b`
//!   (exact on cubics, so a circle's new nodes land on the circle to O(h⁴)), the three-point
//!   rule `3/4 a + 3/8 b − 1/8 p` when only one side continues, and the chord midpoint at a
//!   curve with one segment. A neighbour across a turn sharper than 45°, or an estimate
//!   more than a tenth of the segment (`MAX_BULGE`) away from the chord midpoint, is not used (chord
//!   midpoint instead). New nodes of a straight curve stay on it (affine combinations of
//!   collinear points), so planar areas with straight boundaries are unchanged.
//! - **Face nodes.** A quad's new centre node is the mean of its corners, a triangle's its
//!   centroid; surface edge nodes are chord midpoints. (On curved surfaces the optimizer
//!   projects every node onto the reference triangulation afterwards.)
//! - **Tags.** New nodes get tags above the maximum and are appended to the node block of
//!   their entity (a new block when it has none); parametric blocks get parametric
//!   coordinates averaged from the parent nodes in the same block. The first child of an
//!   element keeps the element's tag, the others get fresh tags above the maximum; a
//!   triangle block becomes a quad block. Children are oriented like their parent.
//! - **Periodic curves and surfaces.** A `$Periodic` link between curves or surfaces gets
//!   a pair for each new node whose segment's two nodes are both paired (with the image
//!   segment's new node); a surface link also pairs each element's centre with the centre
//!   of the master element on the images of its corners. Every new node of a periodic
//!   slave surface gets its pair, or the mesh is refused (its elements are not images of
//!   the master's). The new nodes are placed by the same affine rules on both sides
//!   (chord midpoints, centres; curve nodes by the curve rules, periodic curves being
//!   images of each other), so each pair keeps the link's transform; the optimizer leaves
//!   periodic surfaces as they are, so on a curved periodic surface the new nodes stay
//!   where refinement puts them.
//! - Refused, with nothing changed: volume elements, elements other than points, 2-node
//!   lines, 3-node triangles and 4-node quads (high order), and periodic surfaces whose
//!   elements are not images of their masters'.
//!
//! **Invariant:** existing node tags, coordinates and classifications are kept; every
//! element's first child keeps its tag; entities and physical groups are untouched; the
//! output is conforming whenever the input is; line elements cover the same curves.

use std::collections::HashMap;

use glam::DVec3;

use crate::mesh::{
    classified_curve, element_dim, etype, lined_curves, mean_params, ElementBlock, Mesh, NodeBlock,
    NodeIndex,
};

/// Why a mesh cannot be refined.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum RefineError {
    /// An element block of a type refinement does not handle.
    UnsupportedElements {
        /// Dimension of the block's entity.
        dim: i32,
        /// Tag of the block's entity.
        tag: i32,
        /// Gmsh element type code.
        element_type: u32,
    },
    /// A periodic surface whose refined nodes have no images on its master (its elements
    /// are not the images of the master's).
    PeriodicSurface {
        /// Slave surface tag.
        tag: i32,
    },
    /// An element refers to a node that does not exist.
    MissingNode {
        /// The missing node tag.
        node: u64,
    },
}

impl std::fmt::Display for RefineError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RefineError::UnsupportedElements {
                dim,
                tag,
                element_type,
            } => write!(
                f,
                "cannot refine: entity ({dim}, {tag}) holds elements of type {element_type} \
                 (only points, 2-node lines, 3-node triangles and 4-node quads are refined)"
            ),
            RefineError::PeriodicSurface { tag } => write!(
                f,
                "cannot refine: surface {tag} is periodic, but its elements are not the \
                 images of its master's, so its new nodes would have no periodic counterparts"
            ),
            RefineError::MissingNode { node } => {
                write!(
                    f,
                    "cannot refine: an element uses node {node}, which is not defined"
                )
            }
        }
    }
}

impl std::error::Error for RefineError {}

/// What one level of refinement did.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize)]
pub struct RefineReport {
    /// New nodes (edge and face nodes).
    pub nodes_added: usize,
    /// Quads after refinement.
    pub quads: usize,
    /// 2-node lines after refinement.
    pub lines: usize,
    /// Curve nodes placed by the chord midpoint because no smooth estimate was safe.
    pub curve_midpoints: usize,
}

/// The element that refining a block once ([`refine`]) made element `index` of the refined
/// block a child of, as its index in the block before (`parent`: that block's element type
/// and length) and the corner the child holds: the children of element `i` are elements
/// `k·i .. k·i + k` of the refined block (`k` = 2 for a line, 3 for a triangle, 4 for a
/// quad), child `j` holding the parent's corner `j` (a triangle's or quad's child as its
/// first node), since refinement keeps the blocks in order, one for one. None when the
/// block before has no such element, or is of another type.
pub(crate) fn parent_of(parent: (u32, usize), index: usize) -> Option<(usize, usize)> {
    let k = match parent.0 {
        etype::LINE2 => 2,
        etype::TRI3 => 3,
        etype::QUAD4 => 4,
        _ => return None,
    };
    (index / k < parent.1).then_some((index / k, index % k))
}

/// Largest distance of a curve estimate from its segment's chord midpoint, as a share of
/// the segment's length: a tenth, which a circle meshed with the sharpest turn the estimate
/// crosses ([`MAX_TURN`], 45° per segment) stays within (its arc is 0.0995 of the chord
/// off it). The one-sided rule at a curve's end, an extrapolation, overshoots beyond it
/// near that turn (0.15 of the segment measured at a 42° turn), and is not used there.
const MAX_BULGE: f64 = 0.1;

/// Sharpest turn (radians) between successive curve segments that the curve estimate
/// crosses: 45° (a circle with 8 segments); a sharper turn inside one curve is taken as a
/// corner.
const MAX_TURN: f64 = std::f64::consts::FRAC_PI_4;

/// Undirected edge key.
fn key(a: u64, b: u64) -> (u64, u64) {
    (a.min(b), a.max(b))
}

/// An entity, as (dimension, tag).
type EntityKey = (i32, i32);

/// One new edge node before it gets a tag.
struct EdgeNode {
    edge: (u64, u64),
    /// Classifying entity (dim, tag).
    owner: EntityKey,
}

/// Refines `mesh` once (see the module doc). On error the mesh is unchanged.
pub fn refine(mesh: &mut Mesh) -> Result<RefineReport, RefineError> {
    check_supported(mesh)?;
    let index = mesh.node_index();
    let coord = |t: u64| -> Result<DVec3, RefineError> {
        let r = index.get(t).ok_or(RefineError::MissingNode { node: t })?;
        Ok(DVec3::from_array(
            mesh.node_blocks[r.block as usize].coords[r.index as usize],
        ))
    };
    for b in &mesh.element_blocks {
        for &t in &b.nodes {
            coord(t)?;
        }
    }

    let (edges, slot_edge) = edge_nodes(mesh, &index);
    let mut report = RefineReport::default();
    let chains = CurveChains::new(mesh);

    // positions and owners of all new nodes: edge nodes first, then face centres in block order
    let mut new_pos: Vec<DVec3> = Vec::with_capacity(edges.len());
    let mut new_owner: Vec<(i32, i32)> = Vec::with_capacity(edges.len());
    // parent nodes of each new node (2 for an edge, 3 or 4 for a face), for its parametric
    // coordinates
    let mut new_refs: Vec<([u64; 4], usize)> = Vec::with_capacity(edges.len());
    for e in &edges {
        let (a, b) = e.edge;
        let (pa, pb) = (coord(a)?, coord(b)?);
        let pos = if e.owner.0 == 1 {
            let (p, smooth) = chains.midpoint(e.owner.1, a, b, pa, pb, &coord);
            if !smooth {
                report.curve_midpoints += 1;
            }
            p
        } else {
            0.5 * (pa + pb)
        };
        new_pos.push(pos);
        new_owner.push(e.owner);
        new_refs.push(([a, b, 0, 0], 2));
    }
    let first_tag = mesh.max_node_tag() + 1;
    let mut slot = 0usize;
    // the face centres of the elements of periodic surfaces, by surface and sorted corners
    let periodic_surfaces: std::collections::HashSet<i32> = mesh
        .periodic
        .iter()
        .filter(|l| l.dim == 2)
        .flat_map(|l| [l.tag, l.master_tag])
        .collect();
    let mut centres: HashMap<(i32, [u64; 4]), u64> = HashMap::new();

    // elements
    let mut next_elem = mesh.max_element_tag() + 1;
    let mut blocks = Vec::with_capacity(mesh.element_blocks.len());
    for blk in &mesh.element_blocks {
        let k = blk.nodes_per_element();
        let (children, ty) = match blk.element_type {
            etype::LINE2 => (2, etype::LINE2),
            etype::TRI3 => (3, etype::QUAD4),
            etype::QUAD4 => (4, etype::QUAD4),
            _ => {
                blocks.push(blk.clone());
                continue;
            }
        };
        let mut out = ElementBlock {
            entity_dim: blk.entity_dim,
            entity_tag: blk.entity_tag,
            element_type: ty,
            tags: Vec::with_capacity(children * blk.len()),
            nodes: Vec::with_capacity(
                children * blk.len() * if ty == etype::LINE2 { 2 } else { 4 },
            ),
            partitions: blk
                .partitions
                .as_ref()
                .map(|_| Vec::with_capacity(children * blk.len())),
        };
        for i in 0..blk.len() {
            let el = blk.element(i);
            // the edge nodes, in local-edge order (edge j runs from el[j] to el[j + 1]; a
            // line has one edge)
            let n_edges = if k == 2 { 1 } else { k };
            let mut m = [0u64; 4];
            for (j, t) in m.iter_mut().take(n_edges).enumerate() {
                *t = first_tag + u64::from(slot_edge[slot + j]);
            }
            slot += n_edges;
            let mut pieces = [[0u64; 4]; 4];
            if k == 2 {
                pieces[0][..2].copy_from_slice(&[el[0], m[0]]);
                pieces[1][..2].copy_from_slice(&[m[0], el[1]]);
            } else {
                let c = first_tag + new_pos.len() as u64;
                if blk.entity_dim == 2 && periodic_surfaces.contains(&blk.entity_tag) {
                    // a triangle's corners padded with 0 (no node has tag 0)
                    let mut corners = [0u64; 4];
                    corners[..k].copy_from_slice(el);
                    corners.sort_unstable();
                    centres.insert((blk.entity_tag, corners), c);
                }
                let mut sum = DVec3::ZERO;
                for &t in el {
                    sum += coord(t)?;
                }
                new_pos.push(sum / k as f64);
                new_owner.push((2, blk.entity_tag));
                let mut refs = [0u64; 4];
                refs[..k].copy_from_slice(el);
                new_refs.push((refs, k));
                // child j is the corner el[j] with its two edge nodes and the centre,
                // oriented like the parent
                for (j, p) in pieces.iter_mut().take(k).enumerate() {
                    *p = [el[j], m[j], c, m[(j + k - 1) % k]];
                }
            }
            let width = if k == 2 { 2 } else { 4 };
            for (n, p) in pieces.iter().take(k).map(|p| &p[..width]).enumerate() {
                let tag = if n == 0 {
                    blk.tags[i]
                } else {
                    next_elem += 1;
                    next_elem - 1
                };
                out.tags.push(tag);
                out.nodes.extend_from_slice(p);
                if let (Some(o), Some(src)) = (out.partitions.as_mut(), blk.partitions.as_ref()) {
                    o.push(src.get(i).cloned().unwrap_or_default());
                }
            }
        }
        match ty {
            etype::LINE2 => report.lines += out.len(),
            _ => report.quads += out.len(),
        }
        blocks.push(out);
    }

    // periodic curve links: pair the new node of each paired segment
    let mut periodic = mesh.periodic.clone();
    // the (new node, its image) of each edge `on` accepts whose two nodes `pair` maps to
    // the nodes of an edge
    let image_nodes = |pair: &HashMap<u64, u64>, on: &dyn Fn(&EdgeNode) -> bool| {
        let mut added = Vec::new();
        for (i, e) in edges.iter().enumerate().filter(|(_, e)| on(e)) {
            let (Some(&ma), Some(&mb)) = (pair.get(&e.edge.0), pair.get(&e.edge.1)) else {
                continue;
            };
            if let Ok(j) = edges.binary_search_by_key(&key(ma, mb), |x| x.edge) {
                added.push((first_tag + i as u64, first_tag + j as u64));
            }
        }
        added
    };
    for link in periodic.iter_mut().filter(|l| l.dim == 1) {
        let pair: HashMap<u64, u64> = link.node_pairs.iter().copied().collect();
        let added = image_nodes(&pair, &|e| e.owner == (1, link.tag));
        link.node_pairs.extend(added);
    }
    // periodic surface links: pair the new node of each edge whose two nodes are paired,
    // and the centre of each element whose corners are those of a master element; every
    // new node of the slave surface must get its image
    for link in periodic.iter_mut().filter(|l| l.dim == 2) {
        let pair: HashMap<u64, u64> = link.node_pairs.iter().copied().collect();
        let mut added = image_nodes(&pair, &|_| true);
        for (&(surface, corners), &c) in &centres {
            if surface != link.tag {
                continue;
            }
            let image = corners.map(|v| match v {
                0 => Some(0),
                v => pair.get(&v).copied(),
            });
            let Some(mut image) = image.into_iter().collect::<Option<Vec<u64>>>() else {
                continue;
            };
            image.sort_unstable();
            let image = [image[0], image[1], image[2], image[3]];
            if let Some(&m) = centres.get(&(link.master_tag, image)) {
                added.push((c, m));
            }
        }
        let paired: std::collections::HashSet<u64> = added.iter().map(|p| p.0).collect();
        let unpaired = new_owner
            .iter()
            .enumerate()
            .any(|(i, o)| *o == (2, link.tag) && !paired.contains(&(first_tag + i as u64)));
        if unpaired {
            return Err(RefineError::PeriodicSurface { tag: link.tag });
        }
        added.sort_unstable();
        link.node_pairs.extend(added);
    }

    // new nodes into the blocks of their entities
    report.nodes_added = new_pos.len();
    let mut block_of: HashMap<(i32, i32), usize> = HashMap::new();
    for (bi, b) in mesh.node_blocks.iter().enumerate() {
        block_of.entry((b.entity_dim, b.entity_tag)).or_insert(bi);
    }
    let mut unparametrized = 0usize;
    let mut node_blocks = mesh.node_blocks.clone();
    for (i, ((pos, owner), refs)) in new_pos.iter().zip(&new_owner).zip(&new_refs).enumerate() {
        let bi = *block_of.entry(*owner).or_insert_with(|| {
            node_blocks.push(NodeBlock {
                entity_dim: owner.0,
                entity_tag: owner.1,
                tags: Vec::new(),
                coords: Vec::new(),
                params: None,
            });
            node_blocks.len() - 1
        });
        let np = owner.0.max(0) as usize;
        let blk = &mut node_blocks[bi];
        blk.tags.push(first_tag + i as u64);
        blk.coords.push(pos.to_array());
        if let Some(params) = blk.params.as_mut() {
            let (uv, complete) = mean_params(&mesh.node_blocks, &index, bi, np, &refs.0[..refs.1]);
            if !complete {
                unparametrized += 1;
            }
            params.extend_from_slice(&uv);
        }
    }
    if unparametrized > 0 {
        mesh.warnings.push(format!(
            "refinement: {unparametrized} new node(s) on parametric entities got parametric \
             coordinates averaged from only some of their parent nodes (the others are on \
             another entity)"
        ));
    }
    mesh.node_blocks = node_blocks;
    mesh.element_blocks = blocks;
    mesh.periodic = periodic;
    mesh.invalidate_element_data();
    Ok(report)
}

/// Refuses what [`refine`] cannot handle, before anything changes.
fn check_supported(mesh: &Mesh) -> Result<(), RefineError> {
    for b in &mesh.element_blocks {
        let ok = matches!(
            b.element_type,
            etype::POINT | etype::LINE2 | etype::TRI3 | etype::QUAD4
        ) && element_dim(b.element_type) == Some(b.entity_dim);
        if !ok && !b.is_empty() {
            return Err(RefineError::UnsupportedElements {
                dim: b.entity_dim,
                tag: b.entity_tag,
                element_type: b.element_type,
            });
        }
    }
    Ok(())
}

/// Every edge of every line, triangle and quad, sorted by key, with its classifying entity;
/// and for every element edge, in block, element and local-edge order (the order
/// [`refine`] walks them), the index of its edge in that list.
fn edge_nodes(mesh: &Mesh, index: &NodeIndex) -> (Vec<EdgeNode>, Vec<u32>) {
    // curves with line elements: their edges are those elements, nothing else lies on them
    let lined = lined_curves(mesh);
    // rank: 0 = a line element's curve, 1 = curve from node classification, 2 = a surface
    let mut all: Vec<((u64, u64), u8, EntityKey, u32)> = Vec::new();
    for b in &mesh.element_blocks {
        let k = match b.element_type {
            etype::LINE2 => 2,
            etype::TRI3 => 3,
            etype::QUAD4 => 4,
            _ => continue,
        };
        for i in 0..b.len() {
            let el = b.element(i);
            let slot = all.len() as u32;
            if k == 2 {
                all.push((key(el[0], el[1]), 0, (1, b.entity_tag), slot));
                continue;
            }
            for j in 0..k {
                let (a, c) = (el[j], el[(j + 1) % k]);
                let slot = slot + j as u32;
                match classified_curve(mesh, index, &lined, a, c) {
                    Some(curve) => all.push((key(a, c), 1, (1, curve), slot)),
                    None => all.push((key(a, c), 2, (2, b.entity_tag), slot)),
                }
            }
        }
    }
    all.sort_unstable_by_key(|&(e, rank, _, slot)| (e, rank, slot));
    let mut slot_edge = vec![0u32; all.len()];
    let mut edges: Vec<EdgeNode> = Vec::new();
    for &(edge, _, owner, slot) in &all {
        if edges.last().is_none_or(|e| e.edge != edge) {
            edges.push(EdgeNode { edge, owner });
        }
        slot_edge[slot as usize] = (edges.len() - 1) as u32;
    }
    (edges, slot_edge)
}

/// The line-element neighbours of every node on every curve, to estimate the curve through
/// its nodes.
struct CurveChains {
    /// Sorted `(curve, node, neighbour)` triples, both directions of every line element.
    links: Vec<(i32, u64, u64)>,
}

impl CurveChains {
    fn new(mesh: &Mesh) -> Self {
        let mut links = Vec::new();
        for b in mesh
            .element_blocks
            .iter()
            .filter(|b| b.element_type == etype::LINE2)
        {
            for i in 0..b.len() {
                let el = b.element(i);
                if el[0] != el[1] {
                    links.push((b.entity_tag, el[0], el[1]));
                    links.push((b.entity_tag, el[1], el[0]));
                }
            }
        }
        links.sort_unstable();
        links.dedup();
        CurveChains { links }
    }

    /// The node before `a` on `curve` when `a` has exactly two neighbours there, one being
    /// `b`.
    fn beyond(&self, curve: i32, a: u64, b: u64) -> Option<u64> {
        let lo = self.links.partition_point(|&(c, n, _)| (c, n) < (curve, a));
        let hi = self
            .links
            .partition_point(|&(c, n, _)| (c, n) <= (curve, a));
        match &self.links[lo..hi] {
            [(_, _, x), (_, _, y)] if *x == b => Some(*y),
            [(_, _, x), (_, _, y)] if *y == b => Some(*x),
            _ => None,
        }
    }

    /// The estimated curve point halfway along segment `a b` of `curve`, and whether it is
    /// the smooth estimate (false: the chord midpoint).
    fn midpoint(
        &self,
        curve: i32,
        a: u64,
        b: u64,
        pa: DVec3,
        pb: DVec3,
        coord: &impl Fn(u64) -> Result<DVec3, RefineError>,
    ) -> (DVec3, bool) {
        let chord = 0.5 * (pa + pb);
        let seg = pb - pa;
        // a neighbour is used only when the curve turns gently there
        let gentle = |p: DVec3, from: DVec3, to: DVec3| {
            let (u, v) = (from - p, to - from);
            u.length() > 0.0 && v.length() > 0.0 && u.angle_between(v) <= MAX_TURN
        };
        let p = self
            .beyond(curve, a, b)
            .and_then(|t| coord(t).ok())
            .filter(|&p| gentle(p, pa, pb));
        let q = self
            .beyond(curve, b, a)
            .and_then(|t| coord(t).ok())
            .filter(|&q| gentle(q, pb, pa));
        let est = match (p, q) {
            (Some(p), Some(q)) => (9.0 * (pa + pb) - (p + q)) / 16.0,
            (Some(p), None) => 0.75 * pa + 0.375 * pb - 0.125 * p,
            (None, Some(q)) => 0.75 * pb + 0.375 * pa - 0.125 * q,
            (None, None) => return (chord, false),
        };
        if (est - chord).length() <= MAX_BULGE * seg.length() {
            (est, true)
        } else {
            (chord, false)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::PeriodicLink;

    type Nodes<'a> = &'a [(i32, i32, &'a [(u64, [f64; 3])])];
    type Elements<'a> = &'a [(i32, i32, u32, &'a [(u64, &'a [u64])])];

    fn build(nodes: Nodes, elements: Elements) -> Mesh {
        let mut m = Mesh::default();
        for &(dim, tag, list) in nodes {
            m.node_blocks.push(NodeBlock {
                entity_dim: dim,
                entity_tag: tag,
                tags: list.iter().map(|n| n.0).collect(),
                coords: list.iter().map(|n| n.1).collect(),
                params: None,
            });
        }
        for &(dim, tag, ty, list) in elements {
            m.element_blocks.push(ElementBlock {
                entity_dim: dim,
                entity_tag: tag,
                element_type: ty,
                tags: list.iter().map(|e| e.0).collect(),
                nodes: list.iter().flat_map(|e| e.1.iter().copied()).collect(),
                partitions: None,
            });
        }
        m
    }

    fn coords(m: &Mesh) -> HashMap<u64, DVec3> {
        let mut c = HashMap::new();
        for b in &m.node_blocks {
            for (t, p) in b.tags.iter().zip(&b.coords) {
                assert!(
                    c.insert(*t, DVec3::from_array(*p)).is_none(),
                    "node {t} twice"
                );
            }
        }
        c
    }

    fn faces(m: &Mesh) -> Vec<Vec<u64>> {
        let mut f = Vec::new();
        for b in m.element_blocks.iter().filter(|b| b.entity_dim == 2) {
            for i in 0..b.len() {
                f.push(b.element(i).to_vec());
            }
        }
        f
    }

    fn lines(m: &Mesh) -> Vec<(u64, u64)> {
        let mut l = Vec::new();
        for b in m
            .element_blocks
            .iter()
            .filter(|b| b.element_type == etype::LINE2)
        {
            for i in 0..b.len() {
                l.push(key(b.element(i)[0], b.element(i)[1]));
            }
        }
        l.sort_unstable();
        l
    }

    /// Conformity (every edge in one or two faces, the edges in one face are exactly the
    /// line elements), positive orientation, and the total signed area (planar, z = 0).
    fn check_planar(m: &Mesh) -> f64 {
        let c = coords(m);
        let mut uses: HashMap<(u64, u64), usize> = HashMap::new();
        let mut area = 0.0;
        for f in faces(m) {
            let mut a = 0.0;
            for j in 0..f.len() {
                let (p, q) = (c[&f[j]], c[&f[(j + 1) % f.len()]]);
                a += 0.5 * (p.x * q.y - q.x * p.y);
                *uses.entry(key(f[j], f[(j + 1) % f.len()])).or_default() += 1;
            }
            assert!(
                a > 0.0,
                "face {f:?} not oriented like its parent (area {a})"
            );
            area += a;
        }
        assert!(uses.values().all(|&n| n <= 2), "an edge in 3+ faces");
        let mut boundary: Vec<(u64, u64)> =
            uses.iter().filter(|e| *e.1 == 1).map(|e| *e.0).collect();
        boundary.sort_unstable();
        assert_eq!(
            boundary,
            lines(m),
            "boundary edges differ from the line elements"
        );
        area
    }

    /// The unit square: two triangles, four boundary curves, four corner points.
    fn square() -> Mesh {
        build(
            &[
                (0, 1, &[(1, [0.0, 0.0, 0.0])]),
                (0, 2, &[(2, [1.0, 0.0, 0.0])]),
                (0, 3, &[(3, [1.0, 1.0, 0.0])]),
                (0, 4, &[(4, [0.0, 1.0, 0.0])]),
            ],
            &[
                (0, 1, etype::POINT, &[(20, &[1])]),
                (1, 1, etype::LINE2, &[(11, &[1, 2])]),
                (1, 2, etype::LINE2, &[(12, &[2, 3])]),
                (1, 3, etype::LINE2, &[(13, &[3, 4])]),
                (1, 4, etype::LINE2, &[(14, &[4, 1])]),
                (2, 1, etype::TRI3, &[(7, &[1, 2, 3]), (9, &[1, 3, 4])]),
            ],
        )
    }

    #[test]
    fn triangles_become_three_quads_and_lines_two() {
        let mut m = square();
        let before = coords(&m);
        let r = refine(&mut m).expect("refine");
        assert_eq!((r.quads, r.lines), (6, 8));
        // 5 edges + 2 centres
        assert_eq!(r.nodes_added, 7);
        assert!((check_planar(&m) - 1.0).abs() < 1e-12);
        let after = coords(&m);
        for (t, p) in &before {
            assert_eq!(after.get(t), Some(p), "node {t} moved or vanished");
        }
        assert!(after
            .keys()
            .filter(|t| !before.contains_key(t))
            .all(|&t| t > 4));
        // the first child keeps the parent's tag, the others are fresh and unique
        let mut tags: Vec<u64> = m
            .element_blocks
            .iter()
            .flat_map(|b| b.tags.clone())
            .collect();
        for t in [7, 9, 11, 12, 13, 14, 20] {
            assert!(tags.contains(&t), "element tag {t} lost");
        }
        assert!(m
            .element_blocks
            .iter()
            .all(|b| b.element_type != etype::TRI3));
        tags.sort_unstable();
        let n = tags.len();
        tags.dedup();
        assert_eq!(tags.len(), n, "duplicate element tags");
        // straight curves: exact midpoints, classified on their curve
        let mid = DVec3::new(0.5, 0.0, 0.0);
        let b = m
            .node_blocks
            .iter()
            .find(|b| b.entity_dim == 1 && b.entity_tag == 1)
            .expect("curve 1 got a node block");
        assert_eq!(b.coords.len(), 1);
        assert!((DVec3::from_array(b.coords[0]) - mid).length() < 1e-15);
    }

    /// A square bounded by one curve whose four nodes are all on it: the diagonal joins two
    /// nodes of that curve but is not one of its line elements, so its new node belongs to
    /// the surface, not to the curve (which gets exactly its four segment midpoints).
    #[test]
    fn a_diagonal_between_nodes_of_an_outlined_curve_stays_in_the_surface() {
        let mut m = build(
            &[(
                1,
                1,
                &[
                    (1, [0.0, 0.0, 0.0]),
                    (2, [1.0, 0.0, 0.0]),
                    (3, [1.0, 1.0, 0.0]),
                    (4, [0.0, 1.0, 0.0]),
                ],
            )],
            &[
                (
                    1,
                    1,
                    etype::LINE2,
                    &[(11, &[1, 2]), (12, &[2, 3]), (13, &[3, 4]), (14, &[4, 1])],
                ),
                (2, 1, etype::TRI3, &[(7, &[1, 2, 3]), (9, &[1, 3, 4])]),
            ],
        );
        refine(&mut m).expect("refine");
        assert!((check_planar(&m) - 1.0).abs() < 1e-12);
        let block_of = |p: DVec3| {
            m.node_blocks
                .iter()
                .find(|b| {
                    b.coords
                        .iter()
                        .any(|c| (DVec3::from_array(*c) - p).length() < 1e-12)
                })
                .map(|b| (b.entity_dim, b.entity_tag))
        };
        assert_eq!(block_of(DVec3::new(0.5, 0.5, 0.0)), Some((2, 1)));
        let curve = m
            .node_blocks
            .iter()
            .find(|b| b.entity_dim == 1 && b.entity_tag == 1)
            .expect("curve 1");
        assert_eq!(curve.coords.len(), 8, "4 corners + 4 segment midpoints");
    }

    #[test]
    fn quads_refined_twice_stay_conforming() {
        let mut m = square();
        m.element_blocks[5] = ElementBlock {
            entity_dim: 2,
            entity_tag: 1,
            element_type: etype::QUAD4,
            tags: vec![7],
            nodes: vec![1, 2, 3, 4],
            partitions: Some(vec![vec![3]]),
        };
        refine(&mut m).expect("first");
        let r = refine(&mut m).expect("second");
        assert_eq!((r.quads, r.lines), (16, 16));
        assert!((check_planar(&m) - 1.0).abs() < 1e-12);
        let quads = &m.element_blocks[5];
        assert_eq!(quads.partitions.as_ref().map(|p| p.len()), Some(16));
        // a regular grid: every interior node is in exactly four quads
        let mut valence: HashMap<u64, usize> = HashMap::new();
        for f in faces(&m) {
            for t in f {
                *valence.entry(t).or_default() += 1;
            }
        }
        assert_eq!(valence.values().filter(|&&v| v == 4).count(), 9);
    }

    /// Every child of a refined mesh, refined twice, leads back through `parent_of` to the
    /// element of the mesh before it that holds it: the child holds the parent's corner it
    /// names (a face's child as its first node), its other nodes are new, and a face
    /// child's third node is the mean of the parent's corners.
    #[test]
    fn every_child_leads_back_to_its_parent_and_the_corner_it_holds() {
        let mut levels = vec![square()];
        for _ in 0..2 {
            let mut next = levels[levels.len() - 1].clone();
            refine(&mut next).expect("refine");
            levels.push(next);
        }
        for pair in levels.windows(2) {
            let (before, after) = (&pair[0], &pair[1]);
            let at = coords(after);
            let old = before.max_node_tag();
            let mut children = 0;
            for (b, blk) in after.element_blocks.iter().enumerate() {
                let shape = (before.element_blocks[b].element_type, before.element_blocks[b].len());
                if ![etype::LINE2, etype::QUAD4].contains(&blk.element_type) {
                    assert_eq!(parent_of(shape, 0), None, "block {b}");
                    continue;
                }
                for i in 0..blk.len() {
                    let (p, j) = parent_of(shape, i).expect("a parent");
                    let parent = before.element_blocks[b].element(p);
                    let child = blk.element(i);
                    // a face's child starts at the corner, a line's holds its end
                    let held = if child.len() == 2 { j } else { 0 };
                    assert_eq!(child[held], parent[j], "block {b} child {i}");
                    assert_eq!(child.iter().filter(|&&t| t > old).count(), child.len() - 1);
                    if child.len() == 4 {
                        let mean = parent.iter().map(|t| at[t]).sum::<DVec3>() / parent.len() as f64;
                        assert!((at[&child[2]] - mean).length() < 1e-12);
                    }
                    children += 1;
                }
                assert_eq!(parent_of(shape, blk.len()), None);
            }
            assert!(children > 0);
        }
    }

    /// A disc: a closed curve of `n` nodes on the unit circle and a fan of triangles.
    fn disc(n: usize) -> Mesh {
        let ring: Vec<(u64, [f64; 3])> = (0..n)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                (i as u64 + 1, [a.cos(), a.sin(), 0.0])
            })
            .collect();
        let centre = [(100u64, [0.0, 0.0, 0.0])];
        let segs: Vec<[u64; 2]> = (0..n as u64)
            .map(|i| [i + 1, (i + 1) % n as u64 + 1])
            .collect();
        let tris: Vec<[u64; 3]> = segs.iter().map(|s| [100, s[0], s[1]]).collect();
        let lines: Vec<(u64, &[u64])> = segs.iter().zip(1..).map(|(s, t)| (t, &s[..])).collect();
        let faces: Vec<(u64, &[u64])> = tris.iter().zip(1000..).map(|(s, t)| (t, &s[..])).collect();
        build(
            &[(1, 1, &ring), (2, 1, &centre)],
            &[(1, 1, etype::LINE2, &lines), (2, 1, etype::TRI3, &faces)],
        )
    }

    #[test]
    fn new_curve_nodes_follow_a_circle() {
        let n = 12;
        let mut m = disc(n);
        let r = refine(&mut m).expect("refine");
        assert_eq!(r.curve_midpoints, 0);
        let curve = m
            .node_blocks
            .iter()
            .find(|b| b.entity_dim == 1)
            .expect("curve block");
        assert_eq!(curve.coords.len(), 2 * n);
        let chord_error = 1.0 - (std::f64::consts::PI / n as f64).cos();
        let worst = curve
            .coords
            .iter()
            .map(|p| (DVec3::from_array(*p).length() - 1.0).abs())
            .fold(0.0, f64::max);
        assert!(
            worst < 0.1 * chord_error,
            "new curve nodes {worst} off the circle (chord midpoints: {chord_error})"
        );
        check_planar(&m);
    }

    #[test]
    fn corner_segments_get_chord_midpoints() {
        // curve 1 turns by 90° at node 2: no smooth estimate across the corner
        let mut m = build(
            &[(
                1,
                1,
                &[
                    (1, [0.0, 0.0, 0.0]),
                    (2, [1.0, 0.0, 0.0]),
                    (3, [1.0, 1.0, 0.0]),
                ],
            )],
            &[(1, 1, etype::LINE2, &[(1, &[1, 2]), (2, &[2, 3])])],
        );
        let r = refine(&mut m).expect("refine");
        assert_eq!(r.curve_midpoints, 2);
        let c = coords(&m);
        let mut new: Vec<[f64; 3]> = c
            .iter()
            .filter(|(t, _)| **t > 3)
            .map(|(_, p)| p.to_array())
            .collect();
        new.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
        assert_eq!(new, vec![[0.5, 0.0, 0.0], [1.0, 0.5, 0.0]]);
    }

    #[test]
    fn unsupported_elements_are_refused_and_nothing_changes() {
        let mut m = square();
        m.element_blocks.push(ElementBlock {
            entity_dim: 3,
            entity_tag: 1,
            element_type: 4,
            tags: vec![50],
            nodes: vec![1, 2, 3, 4],
            partitions: None,
        });
        let before = m.clone();
        let e = refine(&mut m).expect_err("tets refused");
        assert_eq!(
            e,
            RefineError::UnsupportedElements {
                dim: 3,
                tag: 1,
                element_type: 4
            }
        );
        assert!(e.to_string().contains("entity (3, 1)"), "{e}");
        assert_eq!(m, before);
    }

    #[test]
    fn periodic_curves_get_paired_new_nodes_and_parameters() {
        let mut m = build(
            &[
                (
                    1,
                    1,
                    &[
                        (1, [0.0, 0.0, 0.0]),
                        (2, [1.0, 0.0, 0.0]),
                        (3, [2.0, 0.0, 0.0]),
                    ],
                ),
                (
                    1,
                    2,
                    &[
                        (4, [0.0, 1.0, 0.0]),
                        (5, [1.0, 1.0, 0.0]),
                        (6, [2.0, 1.0, 0.0]),
                    ],
                ),
            ],
            &[
                (1, 1, etype::LINE2, &[(1, &[1, 2]), (2, &[2, 3])]),
                (1, 2, etype::LINE2, &[(3, &[4, 5]), (4, &[5, 6])]),
            ],
        );
        m.node_blocks[0].params = Some(vec![0.0, 1.0, 2.0]);
        m.periodic.push(PeriodicLink {
            dim: 1,
            tag: 2,
            master_tag: 1,
            affine: None,
            node_pairs: vec![(4, 1), (5, 2), (6, 3)],
        });
        refine(&mut m).expect("refine");
        let c = coords(&m);
        let pairs = &m.periodic[0].node_pairs;
        assert_eq!(pairs.len(), 5);
        for &(s, t) in pairs {
            let d = c[&s] - c[&t];
            assert!((d - DVec3::Y).length() < 1e-12, "pair {s}-{t} offset {d}");
        }
        let u = m.node_blocks[0].params.as_ref().expect("params kept");
        assert_eq!(u.len(), 5);
        let mut new_u = u[3..].to_vec();
        new_u.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
        assert_eq!(new_u, vec![0.5, 1.5]);
    }

    /// Two unit squares of two quads each, the second 1 above the first; surface 2 is the
    /// slave of surface 1, its nodes paired with those below; `crossed`: surface 2's quads
    /// split the square the other way (not images of surface 1's).
    fn periodic_squares(crossed: bool) -> Mesh {
        let grid = |z: f64, first: u64| -> Vec<(u64, [f64; 3])> {
            let mut v = Vec::new();
            for (j, y) in [0.0, 0.5, 1.0].into_iter().enumerate() {
                for (i, x) in [0.0, 0.5, 1.0].into_iter().enumerate() {
                    v.push((first + (3 * j + i) as u64, [x, y, z]));
                }
            }
            v
        };
        // a 3 x 3 grid of nodes n(i, j) = first + 3 j + i
        let (low, high) = (grid(0.0, 1), grid(1.0, 11));
        // two quads of the grid from node `first`, side by side (`vertical` cut) or one
        // above the other, as (element tag, nodes)
        let split = |first: u64, vertical: bool| -> Vec<(u64, Vec<u64>)> {
            let n = |i: u64, j: u64| first + 3 * j + i;
            if vertical {
                vec![
                    (first, vec![n(0, 0), n(1, 0), n(1, 2), n(0, 2)]),
                    (first + 1, vec![n(1, 0), n(2, 0), n(2, 2), n(1, 2)]),
                ]
            } else {
                vec![
                    (first, vec![n(0, 0), n(2, 0), n(2, 1), n(0, 1)]),
                    (first + 1, vec![n(0, 1), n(2, 1), n(2, 2), n(0, 2)]),
                ]
            }
        };
        let mut m = Mesh::default();
        for (tag, nodes, quads) in [(1, &low, split(1, true)), (2, &high, split(11, !crossed))] {
            m.node_blocks.push(NodeBlock {
                entity_dim: 2,
                entity_tag: tag,
                tags: nodes.iter().map(|n| n.0).collect(),
                coords: nodes.iter().map(|n| n.1).collect(),
                params: None,
            });
            m.element_blocks.push(ElementBlock {
                entity_dim: 2,
                entity_tag: tag,
                element_type: etype::QUAD4,
                tags: quads.iter().map(|q| q.0).collect(),
                nodes: quads.iter().flat_map(|q| q.1.iter().copied()).collect(),
                partitions: None,
            });
        }
        m.periodic.push(PeriodicLink {
            dim: 2,
            tag: 2,
            master_tag: 1,
            affine: None,
            node_pairs: (1..=9).map(|k| (10 + k, k)).collect(),
        });
        m
    }

    #[test]
    fn a_periodic_surface_refined_pairs_every_new_node_with_its_image() {
        let mut m = periodic_squares(false);
        refine(&mut m).expect("refine");
        let c = coords(&m);
        let pairs: HashMap<u64, u64> = m.periodic[0].node_pairs.iter().copied().collect();
        let slave: Vec<u64> = m
            .node_blocks
            .iter()
            .filter(|b| b.entity_tag == 2)
            .flat_map(|b| b.tags.iter().copied())
            .collect();
        // 9 nodes, 7 new edge nodes (each quad's 4 edges, one shared) and 2 centres
        assert_eq!(slave.len(), 18);
        assert_eq!(pairs.len(), 18);
        for t in slave {
            let master = pairs[&t];
            let d = c[&t] - c[&master];
            assert!((d - DVec3::Z).length() < 1e-12, "pair {t}-{master} offset {d}");
        }
    }

    #[test]
    fn a_periodic_surface_whose_elements_are_not_images_is_refused_unchanged() {
        let mut m = periodic_squares(true);
        let before = m.clone();
        let e = refine(&mut m).expect_err("the slave's centres have no images");
        assert_eq!(e, RefineError::PeriodicSurface { tag: 2 });
        assert!(e.to_string().contains("not the images of its master"), "{e}");
        assert_eq!(m, before);
    }
}
