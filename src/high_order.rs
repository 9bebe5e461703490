//! Second-order surface meshes: 6-node triangles (Gmsh type 9) with 3-node lines (type 8)
//! on curves in, 9-node quads (type 10) or, with [`ElevateOptions::incomplete`], 8-node quads
//! (type 16) with 3-node lines out. 9- and 8-node quads already in the input (Gmsh's
//! transfinite, layered and recombined faces at order 2) are kept.
//!
//! [`crate::pipeline::quadrangulate`] runs a mesh with 6-node triangles in three steps,
//! the first and the last from here (this module does not run the linear job):
//! 1. **Linear copy** ([`linearize`]): every tri6 becomes the tri3 of its corners, every
//!    quad9 or quad8 the quad4 of its corners and every line3 the line2 of its ends (same
//!    element tags; the linear job keeps existing quads); the high-order nodes no corner uses
//!    are taken out of the node blocks (and out of `$Periodic` pairs). Node tags are kept.
//! 2. **The linear job**: the whole linear pipeline on that copy (matching, parity repair,
//!    fallback, optimization, invariant and validity checks), unchanged. Its new nodes are
//!    numbered above the linear copy's largest tag; they are renumbered above the input's
//!    (one shift of every tag above the linear maximum), so no tag collides with a
//!    high-order node of the input.
//! 3. **Second order again** ([`elevate`]), on the input's curved geometry: on each
//!    surface, the map `Φ` from the flat corner triangles to the curved tri6 surface
//!    (through each triangle's quadratic shape functions; an input quad counts as two
//!    curved triangles about its diagonal 0-2, through its face node or, for an 8-node
//!    quad, its serendipity centre), and the projection onto that
//!    surface (the flat point `p` whose `Φ(p)` differs from the query only along the
//!    normal, found from the closest flat point, [`crate::quality::locate`], by a few
//!    fixed-point steps; a point of a planar surface is its own projection); on each curve,
//!    the chain of input line3 elements. Then:
//!    - an input node the linear job did not move keeps its tag and coordinates;
//!    - the mid-edge node of an input boundary edge (a line3's, or a face edge used once on
//!      its surface) that the linear job split into an even number of pieces becomes the
//!      middle corner of that chain: the new node there takes its tag and coordinates
//!      (`take_split_mid_nodes`);
//!    - a new node on a curve (parity split, fallback split, refinement) lies between the
//!      two ends of one input line3: it goes onto that line3, at the parameter its place
//!      along the chain of new segments gives (the chord-length fraction, snapped to the
//!      dyadic fraction the midpoint splits made: a single split is the parameter
//!      midpoint, i.e. the input's own mid-edge node position);
//!    - any other new or moved corner is projected onto the curved surface;
//!    - an edge of an input element whose two ends did not move keeps the input's mid-edge
//!      node (same tag, same coordinates), and an input 9-node quad whose corners did not
//!      move keeps its face node (so an input quad the linear job kept in place is written
//!      back as it was, its face node dropped for 8-node output);
//!    - any other mid-edge node is, on a curve with line3 elements, the line3 point at the
//!      mean parameter of its ends; else the projection of the midpoint of its (placed)
//!      corners onto the curved surface (a curve edge of no surface and no line3 gets its
//!      straight midpoint); a mid-edge node of a split curve segment is classified on the
//!      curve;
//!    - the face node of a 9-node quad is the projection of the centre its corners and
//!      mid-edge nodes give a serendipity quad (`Σ mid/2 − Σ corner/4`: a curved edge's
//!      bulge spreads over the element instead of folding it).
//!
//! # Validity
//! Every quad must have all the Bézier coefficients of its Jacobian determinant (a
//! polynomial of degree 3 in each reference coordinate, measured about the normal of its
//! straight-sided quad at its centre, as Gmsh measures it) strictly positive
//! ([`quad_valid`]): that implies a positive determinant over the whole element and is
//! what Gmsh's `minSJ` bound certifies; every line3 must run forward along its chord. An
//! element that fails gets straight-sided new nodes (mid-edge nodes at the midpoints of its
//! corners, the face node at the centre of that serendipity quad; the neighbour across each
//! such edge shares the straight edge); one that fails even so gets its moved corners back
//! at the linear job's positions (which the linear validity gate accepted; a straight-sided
//! quad passes exactly when its corners turn positively), and the elements around them
//! straight sides. The report's log names the elements placed straight. What still fails
//! makes the call fail ([`HighOrderError::Invalid`]) unless
//! [`ElevateOptions::allow_invalid`] is set.
//!
//! **Invariant:** the input's corner nodes the linear job kept in place, and its curve
//! nodes, keep tag and coordinates; a kept mid-edge node keeps tag and coordinates, and so
//! does the mid-edge node of a boundary edge split in two or more (as the middle new
//! corner); every new node has a tag above the input's largest; element tags, entities
//! and physical groups are the linear job's (which keeps the input's).

use std::collections::{HashMap, HashSet};
use std::hash::BuildHasherDefault;

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::mesh::NodeTable;
use crate::mesh::{element_dim, element_node_count, etype, ElementBlock, Mesh, NodeBlock};
use crate::quality::jacobian::{min_scaled_jacobian_at_nodes, quad9_derivatives, straight_normal};
use crate::quality::locate::TriSurface;
use crate::recombine::RecombineError;

/// Hasher of the maps below, whose keys are node tags, tag pairs and entity tags: a
/// multiply-rotate step per word (as rustc's FxHash) and a SplitMix64 finish (so that
/// tags in arithmetic progressions still spread over the buckets). Several times faster
/// than the default SipHash on these small keys.
#[derive(Default, Clone, Copy)]
struct TagHasher(u64);

impl std::hash::Hasher for TagHasher {
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }
    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(5) ^ x).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
    fn write_u32(&mut self, x: u32) {
        self.write_u64(u64::from(x));
    }
    fn write_i32(&mut self, x: i32) {
        self.write_u64(u64::from(x as u32));
    }
    fn write_usize(&mut self, x: usize) {
        self.write_u64(x as u64);
    }
    fn finish(&self) -> u64 {
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
}

type FastMap<K, V> = HashMap<K, V, BuildHasherDefault<TagHasher>>;
type FastSet<K> = HashSet<K, BuildHasherDefault<TagHasher>>;

/// Why the second-order path refused a mesh or could not make it valid.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum HighOrderError {
    /// The linear copy was refused as the linear job refuses a mesh (an unknown node, a
    /// malformed block, volume elements).
    #[error(transparent)]
    Recombine(#[from] RecombineError),
    /// An element type the second-order path does not handle.
    #[error("entity ({dim}, {entity}) has {count} elements of type {element_type}; a second-order mesh must have 6-node triangles (type 9, and 3-node triangles), 9- or 8-node quads (types 10, 16) on surfaces and 3-node lines (type 8, and 2-node lines) on curves: mesh with Mesh.ElementOrder = 2 or 1")]
    Unsupported {
        /// Entity dimension.
        dim: i32,
        /// Entity tag.
        entity: i32,
        /// Gmsh element type code.
        element_type: u32,
        /// How many.
        count: usize,
    },
    /// Second-order quads whose Jacobian is not positive even with straight-sided nodes.
    #[error("{count} second-order element(s) have a Jacobian determinant that is not positive everywhere even with straight-sided nodes; first: element {element} on entity ({dim}, {entity})")]
    Invalid {
        /// Entity dimension of the first bad element.
        dim: i32,
        /// Entity tag of the first bad element.
        entity: i32,
        /// Its element tag.
        element: u64,
        /// How many elements are bad.
        count: usize,
    },
}

/// What the second-order step did.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct SecondOrderReport {
    /// Gmsh type of the quads written (10 = 9-node, 16 = 8-node).
    pub quad_type: u32,
    /// Quads written.
    pub quads: usize,
    /// 3-node lines written.
    pub lines: usize,
    /// Input mid-edge nodes kept (tag and coordinates).
    pub kept_mid_nodes: usize,
    /// New mid-edge nodes on curves (on the input's line3 chains).
    pub curve_mid_nodes: usize,
    /// New mid-edge nodes on surfaces (on the input's curved surface).
    pub surface_mid_nodes: usize,
    /// New face nodes (9-node quads).
    pub face_nodes: usize,
    /// Face nodes of input 9-node quads kept (tag and coordinates).
    pub kept_face_nodes: usize,
    /// New or moved corner nodes placed on the curved geometry.
    pub corners_placed: usize,
    /// Tags of the elements given straight-sided new nodes to stay valid.
    pub straight: Vec<u64>,
    /// Corner nodes put back at the linear position to keep an element valid.
    pub corners_reverted: usize,
    /// Elements still not valid (only with `allow_invalid`).
    pub invalid: Vec<u64>,
    /// Smallest scaled Jacobian at the nodes over all quads.
    pub min_scaled_jacobian: f64,
    /// Mean over quads of their smallest scaled Jacobian at the nodes.
    pub mean_scaled_jacobian: f64,
}

/// True when `mesh` has 6-node triangles, or 9- or 8-node quads, on some surface (the
/// second-order path).
pub fn is_second_order(mesh: &Mesh) -> bool {
    mesh.element_blocks.iter().any(|b| {
        b.entity_dim == 2
            && matches!(b.element_type, etype::TRI6 | etype::QUAD9 | etype::QUAD8)
            && !b.is_empty()
    })
}

/// How [`elevate`] builds and checks the second-order elements.
#[derive(Debug, Clone, Copy, Default)]
pub struct ElevateOptions {
    /// 8-node quads (type 16) instead of 9-node ones.
    pub incomplete: bool,
    /// Write elements whose Jacobian is not positive everywhere (listed in
    /// [`SecondOrderReport::invalid`]) instead of refusing them.
    pub allow_invalid: bool,
}

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

/// Sorted pair of node tags: the key of an edge.
fn key(a: u64, b: u64) -> (u64, u64) {
    if a < b {
        (a, b)
    } else {
        (b, a)
    }
}

/// Point of the 3-node line `(a, b, m)` (ends at ξ = -1 and 1, `m` at 0) at `xi`.
pub fn line3_point(a: DVec3, b: DVec3, m: DVec3, xi: f64) -> DVec3 {
    a * (0.5 * xi * (xi - 1.0)) + b * (0.5 * xi * (xi + 1.0)) + m * (1.0 - xi * xi)
}

/// Point of the 6-node triangle `x` (Gmsh order: corners, then mid-edge nodes of edges
/// 0-1, 1-2, 2-0) at barycentric coordinates `l` (weights of corners 0, 1, 2).
pub fn tri6_point(x: &[DVec3; 6], l: [f64; 3]) -> DVec3 {
    let [a, b, c] = l;
    x[0] * (a * (2.0 * a - 1.0))
        + x[1] * (b * (2.0 * b - 1.0))
        + x[2] * (c * (2.0 * c - 1.0))
        + x[3] * (4.0 * a * b)
        + x[4] * (4.0 * b * c)
        + x[5] * (4.0 * c * a)
}

/// One surface of the input: its flat corner triangles (to locate points) and their six
/// nodes (to map them onto the curved surface).
struct SurfaceGeometry {
    locator: TriSurface,
    six: Vec<[DVec3; 6]>,
    /// A triangle at each input corner node: where searches near that node start.
    node_tri: FastMap<u64, u32>,
}

impl SurfaceGeometry {
    /// The point of the curved surface nearest `q` (to first order): the flat point `p`
    /// whose image `Φ(p)` differs from `q` only along the normal, found by fixed-point
    /// steps from the flat point closest to `q` (`Φ` is the identity plus a small
    /// distortion, so a few steps converge). Returns `q` itself when `q` is already on the
    /// curved surface to rounding (a planar surface's points do not move).
    /// `near`: input corner nodes close to `q`, whose triangles the search starts from (a
    /// walk across a few triangles instead of a search of the whole surface).
    fn project(&self, q: DVec3, near: &[u64]) -> Option<DVec3> {
        let start = near.iter().find_map(|t| self.node_tri.get(t));
        let mut hit = match start {
            Some(&t) => self.locator.walk(t, q)?,
            None => self.locator.closest(q)?,
        };
        let mut best: Option<(f64, DVec3, f64)> = None;
        for _ in 0..8 {
            let x = self.six.get(hit.tri as usize)?;
            let size = (x[1] - x[0]).length() + (x[2] - x[1]).length() + (x[0] - x[2]).length();
            let y = tri6_point(x, hit.bary);
            let r = q - y;
            let n = self.locator.normal(hit.tri);
            let rt = r - n * r.dot(n);
            let err = rt.length();
            // converged, or no longer converging (rounding level): the best point so far
            let stalled = best.is_some_and(|(e, _, _)| err > 0.5 * e);
            if best.is_none_or(|(e, _, _)| err < e) {
                best = Some((err, y, size));
            }
            if err <= 1e-13 * size || stalled {
                break;
            }
            hit = self.locator.walk(hit.tri, hit.point + rt)?;
        }
        let (_, y, size) = best?;
        if y.distance(q) <= 1e-12 * size {
            return Some(q);
        }
        Some(y)
    }
}

/// The input's curved geometry.
struct Geometry<'a> {
    input: &'a Mesh,
    /// Every input node (coordinates by tag).
    nodes: NodeTable,
    /// Input edge (sorted corner tags) -> its mid-edge node.
    mid: FastMap<(u64, u64), u64>,
    /// Input 9-node quad (sorted corner tags) -> its face node.
    face: FastMap<[u64; 4], u64>,
    surfaces: FastMap<i32, SurfaceGeometry>,
    /// Input line3 elements per curve: `[a, b, m]`.
    curves: FastMap<i32, Vec<[u64; 3]>>,
}

impl<'a> Geometry<'a> {
    /// Coordinates of input node `t`.
    fn at(&self, t: u64) -> Option<DVec3> {
        self.nodes.at(t)
    }

    /// Entity (dim, tag) of input node `t`, and its parametric coordinates if any.
    fn owner(&self, t: u64) -> Option<(i32, i32, Option<Vec<f64>>)> {
        let r = self.nodes.node_ref(t)?;
        let b = self.input.node_blocks.get(r.block as usize)?;
        let np = b.entity_dim.max(0) as usize;
        let i = r.index as usize;
        let params = b
            .params
            .as_ref()
            .and_then(|p| p.get(i * np..(i + 1) * np))
            .map(|p| p.to_vec());
        Some((b.entity_dim, b.entity_tag, params))
    }

    fn new(input: &'a Mesh) -> Geometry<'a> {
        let nodes = NodeTable::new(input);
        let coords = &nodes;
        let mut mid = FastMap::default();
        let mut face = FastMap::default();
        let mut curves: FastMap<i32, Vec<[u64; 3]>> = FastMap::default();
        // per surface: curved triangles as corner tags and mid-edge points (edges 0-1,
        // 1-2, 2-0; `None`: the straight midpoint)
        type Piece = ([u64; 3], [Option<DVec3>; 3]);
        let mut tris: FastMap<i32, Vec<Piece>> = FastMap::default();
        let at = |t: u64| coords.at(t);
        for b in &input.element_blocks {
            match (b.entity_dim, b.element_type) {
                (2, etype::TRI6) => {
                    for e in b.nodes.chunks_exact(6) {
                        mid.insert(key(e[0], e[1]), e[3]);
                        mid.insert(key(e[1], e[2]), e[4]);
                        mid.insert(key(e[2], e[0]), e[5]);
                        tris.entry(b.entity_tag)
                            .or_default()
                            .push(([e[0], e[1], e[2]], [at(e[3]), at(e[4]), at(e[5])]));
                    }
                }
                (2, etype::TRI3) => {
                    for e in b.nodes.chunks_exact(3) {
                        // no mid-edge nodes: the flat triangle
                        tris.entry(b.entity_tag)
                            .or_default()
                            .push(([e[0], e[1], e[2]], [None; 3]));
                    }
                }
                (2, etype::QUAD9 | etype::QUAD8) => {
                    let k = b.nodes_per_element();
                    for e in b.nodes.chunks_exact(k) {
                        for j in 0..4 {
                            mid.insert(key(e[j], e[(j + 1) % 4]), e[4 + j]);
                        }
                        // the surface the quad covers, as two curved triangles about the
                        // diagonal 0-2, whose middle is the face node (for an 8-node quad,
                        // its serendipity centre)
                        let x: Option<Vec<DVec3>> = e.iter().map(|&t| at(t)).collect();
                        let Some(x) = x else { continue };
                        let centre = if k == 9 {
                            let mut c = [e[0], e[1], e[2], e[3]];
                            c.sort_unstable();
                            face.insert(c, e[8]);
                            x[8]
                        } else {
                            (x[4] + x[5] + x[6] + x[7]) * 0.5 - (x[0] + x[1] + x[2] + x[3]) * 0.25
                        };
                        let list = tris.entry(b.entity_tag).or_default();
                        list.push(([e[0], e[1], e[2]], [Some(x[4]), Some(x[5]), Some(centre)]));
                        list.push(([e[0], e[2], e[3]], [Some(centre), Some(x[6]), Some(x[7])]));
                    }
                }
                (1, etype::LINE3) => {
                    for e in b.nodes.chunks_exact(3) {
                        mid.insert(key(e[0], e[1]), e[2]);
                        curves
                            .entry(b.entity_tag)
                            .or_default()
                            .push([e[0], e[1], e[2]]);
                    }
                }
                _ => {}
            }
        }
        let surfaces = tris
            .into_par_iter()
            .map(|(s, list)| {
                let mut index: FastMap<u64, u32> = FastMap::default();
                let mut points = Vec::new();
                let mut flat = Vec::with_capacity(list.len());
                let mut six = Vec::with_capacity(list.len());
                let at = |t: u64| coords.at(t).unwrap_or(DVec3::ZERO);
                let mut node_tri = FastMap::default();
                for (ti, (t, _)) in list.iter().enumerate() {
                    for &n in t {
                        node_tri.entry(n).or_insert(ti as u32);
                    }
                }
                for (t, m) in &list {
                    let mut f = [0u32; 3];
                    for (k, &n) in t.iter().enumerate() {
                        f[k] = *index.entry(n).or_insert_with(|| {
                            points.push(at(n));
                            (points.len() - 1) as u32
                        });
                    }
                    flat.push(f);
                    let c = [at(t[0]), at(t[1]), at(t[2])];
                    let m = |k: usize, i: usize, j: usize| m[k].unwrap_or((c[i] + c[j]) * 0.5);
                    six.push([c[0], c[1], c[2], m(0, 0, 1), m(1, 1, 2), m(2, 2, 0)]);
                }
                (
                    s,
                    SurfaceGeometry {
                        locator: TriSurface::new(points, flat),
                        six,
                        node_tri,
                    },
                )
            })
            .collect();
        Geometry {
            input,
            nodes,
            mid,
            face,
            surfaces,
            curves,
        }
    }
}

/// How a mid-edge node is placed.
#[derive(Debug, Clone, Copy, PartialEq)]
enum MidKind {
    /// The input's mid-edge node, kept.
    Kept(u64),
    /// On an input line3 chain.
    Curve,
    /// On the input's curved surface.
    Surface,
    /// Straight midpoint (no curved geometry known).
    Plain,
}

struct Edge {
    a: u64,
    b: u64,
    kind: MidKind,
    curved: DVec3,
    straight: bool,
    /// Entity the mid-edge node is classified on.
    owner: (i32, i32),
    /// A surface holding the edge (the first quad's), where its node is projected.
    surface: Option<i32>,
}

/// Step 3 of the module doc: the second-order mesh from the linear job's result `out`
/// (`linear_max`: the largest node tag of the linear copy it started from).
pub fn elevate(
    input: &Mesh,
    mut out: Mesh,
    linear_max: u64,
    opts: ElevateOptions,
) -> Result<(Mesh, SecondOrderReport), HighOrderError> {
    let input_max = input.max_node_tag();
    // new nodes of the linear job above the input's tags
    let shift = input_max.saturating_sub(linear_max);
    if shift > 0 {
        let up = |t: &mut u64| {
            if *t > linear_max {
                *t += shift;
            }
        };
        for b in &mut out.node_blocks {
            b.tags.iter_mut().for_each(up);
        }
        for b in &mut out.element_blocks {
            b.nodes.iter_mut().for_each(up);
        }
        for l in &mut out.periodic {
            for (a, b) in &mut l.node_pairs {
                up(a);
                up(b);
            }
        }
    }
    let geo = Geometry::new(input);
    // an input mid-edge node whose edge the linear job split becomes the middle corner of
    // the split chain
    let taken = take_split_mid_nodes(&mut out, &geo, input_max);
    // the linear job's nodes (flat positions)
    let flat = NodeTable::new(&out);
    let pos = |t: u64| flat.at(t).unwrap_or(DVec3::ZERO);
    let moved = |t: u64| geo.at(t).is_none_or(|c| Some(c) != flat.at(t));

    // the quads and curve lines of the result
    let mut quads: Vec<(i32, [u64; 4])> = Vec::new();
    let mut quad_at: Vec<(usize, usize)> = Vec::new();
    let mut lines: Vec<(i32, [u64; 2])> = Vec::new();
    for (bi, b) in out.element_blocks.iter().enumerate() {
        match (b.entity_dim, b.element_type) {
            (2, etype::QUAD4) => {
                for (i, e) in b.nodes.chunks_exact(4).enumerate() {
                    quads.push((b.entity_tag, [e[0], e[1], e[2], e[3]]));
                    quad_at.push((bi, i));
                }
            }
            (1, etype::LINE2) => {
                for e in b.nodes.chunks_exact(2) {
                    lines.push((b.entity_tag, [e[0], e[1]]));
                }
            }
            _ => {}
        }
    }

    // curve nodes: chains of new segments between the ends of an input line3
    let mut curve_pos: FastMap<u64, DVec3> = FastMap::default();
    let mut curve_mid: FastMap<(u64, u64), DVec3> = FastMap::default();
    let mut adjacency: FastMap<(i32, u64), Vec<u64>> = FastMap::default();
    for &(c, [a, b]) in &lines {
        adjacency.entry((c, a)).or_default().push(b);
        adjacency.entry((c, b)).or_default().push(a);
    }
    for (&c, list) in &geo.curves {
        for &[a, b, m] in list {
            // a line naming a node the file does not have gets no curved geometry
            let (Some(xa), Some(xb), Some(xm)) = (geo.at(a), geo.at(b), geo.at(m)) else {
                continue;
            };
            if moved(a) || moved(b) {
                continue;
            }
            let is_new = |t: u64| geo.at(t).is_none() || taken.contains(&t);
            let Some(chain) = chain_between(&adjacency, c, a, b, &is_new) else {
                continue;
            };
            let pts: Vec<DVec3> = chain.iter().map(|&t| pos(t)).collect();
            let xi = chain_parameters(&pts);
            for (k, &t) in chain.iter().enumerate() {
                if k > 0 && k + 1 < chain.len() {
                    curve_pos.insert(t, line3_point(xa, xb, xm, xi[k]));
                }
                if k + 1 < chain.len() {
                    let mid_xi = 0.5 * (xi[k] + xi[k + 1]);
                    curve_mid.insert(key(t, chain[k + 1]), line3_point(xa, xb, xm, mid_xi));
                }
            }
        }
    }

    // corners: kept, on a curve, or lifted onto the curved surface
    let mut surface_of: FastMap<u64, i32> = FastMap::default();
    for &(s, q) in &quads {
        for t in q {
            surface_of.entry(t).or_insert(s);
        }
    }
    let mut candidates: Vec<u64> = out
        .node_blocks
        .iter()
        .flat_map(|b| b.tags.iter().copied())
        .filter(|&t| moved(t))
        .collect();
    candidates.sort_unstable();
    candidates.dedup();
    let placed: Vec<(u64, DVec3)> = candidates
        .par_iter()
        .filter_map(|&t| {
            if let Some(&p) = curve_pos.get(&t) {
                return Some((t, p));
            }
            let s = surface_of.get(&t)?;
            let p = geo.surfaces.get(s)?.project(pos(t), &[t])?;
            Some((t, p))
        })
        .collect();
    // corners on the curved geometry: the lifted ones, else the flat positions
    let mut lifted_at: FastMap<u64, DVec3> = FastMap::default();
    for &(t, p) in &placed {
        if p.is_finite() && p != pos(t) {
            lifted_at.insert(t, p);
        }
    }
    let lifted = &lifted_at;
    let corner_at = |t: u64| lifted_at.get(&t).copied().unwrap_or_else(|| pos(t));

    // edges
    let mut edge_of: FastMap<(u64, u64), usize> = FastMap::default();
    let mut edges: Vec<Edge> = Vec::new();
    let mut new_edge = |a: u64, b: u64, owner: (i32, i32), edges: &mut Vec<Edge>| -> usize {
        *edge_of.entry(key(a, b)).or_insert_with(|| {
            edges.push(Edge {
                a,
                b,
                kind: MidKind::Plain,
                curved: DVec3::ZERO,
                straight: false,
                owner,
                surface: None,
            });
            edges.len() - 1
        })
    };
    let mut line_edges = Vec::with_capacity(lines.len());
    for &(c, [a, b]) in &lines {
        line_edges.push(new_edge(a, b, (1, c), &mut edges));
    }
    // entity of every node of the result, for edges along curves without line elements
    let node_entity: FastMap<u64, (i32, i32)> = out
        .node_blocks
        .iter()
        .flat_map(|b| {
            b.tags
                .iter()
                .map(move |&t| (t, (b.entity_dim, b.entity_tag)))
        })
        .collect();
    let bounds = |curve: i32, point: i32| {
        out.entity(1, curve)
            .is_some_and(|e| e.bounding.iter().any(|&p| p.abs() == point))
    };
    // a new edge whose ends are on one curve (or on it and a point bounding it) is a piece
    // of a split curve segment: its mid-edge node is classified on the curve, as Gmsh does
    let edge_owner = |a: u64, b: u64, s: i32| -> (i32, i32) {
        match (node_entity.get(&a), node_entity.get(&b)) {
            (Some(&(1, x)), Some(&(1, y))) if x == y => (1, x),
            (Some(&(1, x)), Some(&(0, p))) | (Some(&(0, p)), Some(&(1, x))) if bounds(x, p) => {
                (1, x)
            }
            _ => (2, s),
        }
    };
    let mut quad_edges = Vec::with_capacity(quads.len());
    for &(s, q) in &quads {
        let mut e = [0usize; 4];
        for k in 0..4 {
            let (a, b) = (q[k], q[(k + 1) % 4]);
            e[k] = new_edge(a, b, edge_owner(a, b, s), &mut edges);
        }
        for &i in &e {
            edges[i].surface.get_or_insert(s);
        }
        quad_edges.push(e);
    }
    edges.par_iter_mut().for_each(|e| {
        let k = key(e.a, e.b);
        let at = corner_at;
        let mid_pt = (at(e.a) + at(e.b)) * 0.5;
        if let (false, false, Some(&m)) = (moved(e.a), moved(e.b), geo.mid.get(&k)) {
            if let Some(x) = geo.at(m) {
                e.kind = MidKind::Kept(m);
                e.curved = x;
                return;
            }
        }
        if let Some(&x) = curve_mid.get(&k) {
            e.kind = MidKind::Curve;
            e.curved = x;
            return;
        }
        if let Some(s) = e.surface {
            if let Some(x) = geo
                .surfaces
                .get(&s)
                .and_then(|g| g.project(mid_pt, &[e.a, e.b]))
            {
                e.kind = MidKind::Surface;
                e.curved = x;
                return;
            }
        }
        e.kind = MidKind::Plain;
        e.curved = mid_pt;
    });
    // a curve edge that is also a quad edge: classified on the curve (first owner wins)

    let complete = !opts.incomplete;
    // the face node: the serendipity centre of the curved corners and mid-edge nodes (a
    // curved edge's bulge spreads evenly over the element), projected onto the surface
    // an input 9-node quad kept with its corners in place keeps its face node
    let face_kept: Vec<Option<u64>> = quads
        .iter()
        .map(|&(_, q)| {
            if !complete || q.iter().any(|&t| moved(t)) {
                return None;
            }
            let mut k = q;
            k.sort_unstable();
            geo.face.get(&k).copied().filter(|&t| geo.at(t).is_some())
        })
        .collect();
    let mut face: Vec<DVec3> = if complete {
        quads
            .par_iter()
            .enumerate()
            .map(|(i, &(s, q))| {
                if let Some(x) = face_kept[i].and_then(|t| geo.at(t)) {
                    return x;
                }
                let mut x = [DVec3::ZERO; 9];
                for k in 0..4 {
                    x[k] = corner_at(q[k]);
                    x[4 + k] = edges[quad_edges[i][k]].curved;
                }
                let c = serendipity_centre(&x);
                geo.surfaces
                    .get(&s)
                    .and_then(|g| g.project(c, &q))
                    .unwrap_or(c)
            })
            .collect()
    } else {
        Vec::new()
    };
    let mut face_straight = vec![!complete; quads.len()];
    face.resize(quads.len(), DVec3::ZERO);

    // validity: straighten, then put corners back, until every element is valid
    let mut reverted: FastSet<u64> = FastSet::default();
    let mut straight_elems: FastSet<u64> = FastSet::default();
    let mut bad_quads: Vec<usize>;
    let mut bad_lines: Vec<usize>;
    let node = |t: u64, reverted: &FastSet<u64>| {
        if reverted.contains(&t) {
            pos(t)
        } else {
            corner_at(t)
        }
    };
    let mid_of = |e: &Edge, reverted: &FastSet<u64>| {
        if e.straight {
            (node(e.a, reverted) + node(e.b, reverted)) * 0.5
        } else {
            e.curved
        }
    };
    let quad_points = |i: usize, edges: &[Edge], fs: &[bool], rv: &FastSet<u64>| -> [DVec3; 9] {
        let q = quads[i].1;
        let mut x = [DVec3::ZERO; 9];
        for k in 0..4 {
            x[k] = node(q[k], rv);
            x[4 + k] = mid_of(&edges[quad_edges[i][k]], rv);
        }
        x[8] = if fs[i] {
            serendipity_centre(&x)
        } else {
            face[i]
        };
        x
    };
    let mut rounds = 0;
    loop {
        rounds += 1;
        bad_quads = (0..quads.len())
            .into_par_iter()
            .filter(|&i| {
                let x = quad_points(i, &edges, &face_straight, &reverted);
                let q = quads[i].1;
                let flat_n = (pos(q[2]) - pos(q[0])).cross(pos(q[3]) - pos(q[1]));
                !quad_valid(&x, flat_n)
            })
            .collect();
        bad_lines = (0..lines.len())
            .filter(|&i| {
                let [a, b] = lines[i].1;
                let e = &edges[line_edges[i]];
                !line_valid(node(a, &reverted), node(b, &reverted), mid_of(e, &reverted))
            })
            .collect();
        if (bad_quads.is_empty() && bad_lines.is_empty()) || rounds > 12 {
            break;
        }
        let mut changed = false;
        for &i in &bad_lines {
            let e = &mut edges[line_edges[i]];
            if !e.straight {
                e.straight = true;
                changed = true;
            } else {
                for t in [e.a, e.b] {
                    if lifted.contains_key(&t) && reverted.insert(t) {
                        changed = true;
                    }
                }
            }
        }
        for &i in &bad_quads {
            let all_straight = face_straight[i] && quad_edges[i].iter().all(|&e| edges[e].straight);
            if !all_straight {
                face_straight[i] = true;
                for &e in &quad_edges[i] {
                    edges[e].straight = true;
                }
                changed = true;
            } else {
                for t in quads[i].1 {
                    if lifted.contains_key(&t) && reverted.insert(t) {
                        changed = true;
                    }
                }
            }
        }
        // nodes placed from a corner now put back: straight around that corner
        if !reverted.is_empty() {
            for e in edges.iter_mut() {
                if reverted.contains(&e.a) || reverted.contains(&e.b) {
                    e.straight = true;
                }
            }
            for (i, (_, q)) in quads.iter().enumerate() {
                if q.iter().any(|t| reverted.contains(t)) {
                    face_straight[i] = true;
                }
            }
        }
        if !changed {
            break;
        }
    }
    // which elements ended up with straight-sided new nodes
    for (i, &(bi, ei)) in quad_at.iter().enumerate() {
        let straight = quad_edges[i]
            .iter()
            .any(|&e| edges[e].straight && edges[e].kind != MidKind::Plain)
            || (complete && face_straight[i]);
        if straight {
            straight_elems.insert(out.element_blocks[bi].tags[ei]);
        }
    }
    let mut bad_tags: Vec<(i32, i32, u64)> = Vec::new();
    for &i in &bad_quads {
        let (bi, ei) = quad_at[i];
        let b = &out.element_blocks[bi];
        bad_tags.push((b.entity_dim, b.entity_tag, b.tags[ei]));
    }
    if !bad_lines.is_empty() {
        let mut k = 0;
        for b in &out.element_blocks {
            if (b.entity_dim, b.element_type) != (1, etype::LINE2) {
                continue;
            }
            for &t in &b.tags {
                if bad_lines.binary_search(&k).is_ok() {
                    bad_tags.push((1, b.entity_tag, t));
                }
                k += 1;
            }
        }
    }
    if let (false, false, Some(first)) = (opts.allow_invalid, bad_tags.is_empty(), bad_tags.first())
    {
        return Err(HighOrderError::Invalid {
            dim: first.0,
            entity: first.1,
            element: first.2,
            count: bad_tags.len(),
        });
    }

    // quality at the nodes
    let sj: Vec<f64> = (0..quads.len())
        .into_par_iter()
        .map(|i| {
            let x = quad_points(i, &edges, &face_straight, &reverted);
            min_scaled_jacobian_at_nodes(&x)
        })
        .collect();

    // new node tags and placement
    let mut next = out.max_node_tag().max(input_max) + 1;
    let mut report = SecondOrderReport {
        quad_type: if complete { etype::QUAD9 } else { etype::QUAD8 },
        quads: quads.len(),
        lines: lines.len(),
        corners_reverted: reverted.len(),
        min_scaled_jacobian: sj.iter().copied().fold(f64::INFINITY, f64::min),
        mean_scaled_jacobian: if sj.is_empty() {
            0.0
        } else {
            sj.iter().sum::<f64>() / sj.len() as f64
        },
        ..Default::default()
    };
    if sj.is_empty() {
        report.min_scaled_jacobian = 0.0;
    }
    let out_index = out.node_index();
    let mut block_of: FastMap<(i32, i32), usize> = FastMap::default();
    for (bi, b) in out.node_blocks.iter().enumerate() {
        block_of.entry((b.entity_dim, b.entity_tag)).or_insert(bi);
    }
    // (entity dim, entity tag, node tag, coordinates, parametric coordinates)
    type NewNode = (i32, i32, u64, DVec3, Option<Vec<f64>>);
    let mut additions: Vec<NewNode> = Vec::new();
    let old_blocks = out.node_blocks.clone();
    let params_for = |owner: (i32, i32), parents: &[u64]| -> Option<Vec<f64>> {
        let bi = *block_of.get(&owner)?;
        old_blocks[bi].params.as_ref()?;
        let np = owner.0.max(0) as usize;
        Some(crate::mesh::mean_params(&old_blocks, &out_index, bi, np, parents).0)
    };
    let mut edge_tag = vec![0u64; edges.len()];
    for (i, e) in edges.iter().enumerate() {
        match (e.kind, e.straight) {
            (MidKind::Kept(m), false) => {
                edge_tag[i] = m;
                report.kept_mid_nodes += 1;
                let (d, t, p) = geo.owner(m).unwrap_or((e.owner.0, e.owner.1, None));
                additions.push((d, t, m, e.curved, p));
            }
            (kind, straight) => {
                edge_tag[i] = next;
                next += 1;
                match (kind, straight) {
                    (MidKind::Curve, false) => report.curve_mid_nodes += 1,
                    (MidKind::Surface, false) => report.surface_mid_nodes += 1,
                    _ => {}
                }
                let x = mid_of(e, &reverted);
                additions.push((
                    e.owner.0,
                    e.owner.1,
                    edge_tag[i],
                    x,
                    params_for(e.owner, &[e.a, e.b]),
                ));
            }
        }
    }
    let mut face_tag = vec![0u64; quads.len()];
    if complete {
        for i in 0..quads.len() {
            let x = quad_points(i, &edges, &face_straight, &reverted)[8];
            let s = quads[i].0;
            if let (Some(t), false) = (face_kept[i], face_straight[i]) {
                face_tag[i] = t;
                report.kept_face_nodes += 1;
                let (d, e, p) = geo.owner(t).unwrap_or((2, s, None));
                additions.push((d, e, t, x, p));
                continue;
            }
            face_tag[i] = next;
            next += 1;
            report.face_nodes += 1;
            additions.push((2, s, face_tag[i], x, params_for((2, s), &quads[i].1)));
        }
    }
    // corners placed on the curved geometry
    let mut corners_placed = 0usize;
    for b in &mut out.node_blocks {
        for (i, &t) in b.tags.iter().enumerate() {
            if lifted.contains_key(&t) && !reverted.contains(&t) {
                if let Some(p) = lifted_at.get(&t) {
                    b.coords[i] = p.to_array();
                }
                corners_placed += 1;
            }
        }
    }
    report.corners_placed = corners_placed;
    for (d, t, tag, x, p) in additions {
        let bi = *block_of.entry((d, t)).or_insert_with(|| {
            out.node_blocks.push(NodeBlock {
                entity_dim: d,
                entity_tag: t,
                tags: Vec::new(),
                coords: Vec::new(),
                params: None,
            });
            out.node_blocks.len() - 1
        });
        let blk = &mut out.node_blocks[bi];
        let np = d.max(0) as usize;
        if let Some(params) = blk.params.as_mut() {
            let mut p = p.unwrap_or_default();
            p.resize(np, 0.0);
            params.extend_from_slice(&p);
        }
        blk.tags.push(tag);
        blk.coords.push(x.to_array());
    }

    // elements
    let mut qi = 0usize;
    let mut li = 0usize;
    let qtype = report.quad_type;
    for b in &mut out.element_blocks {
        match (b.entity_dim, b.element_type) {
            (2, etype::QUAD4) => {
                let k = if complete { 9 } else { 8 };
                let mut nodes = Vec::with_capacity(b.len() * k);
                for e in b.nodes.chunks_exact(4) {
                    nodes.extend_from_slice(e);
                    for &ei in &quad_edges[qi] {
                        nodes.push(edge_tag[ei]);
                    }
                    if complete {
                        nodes.push(face_tag[qi]);
                    }
                    qi += 1;
                }
                b.nodes = nodes;
                b.element_type = qtype;
            }
            (1, etype::LINE2) => {
                let mut nodes = Vec::with_capacity(b.len() * 3);
                for e in b.nodes.chunks_exact(2) {
                    nodes.extend_from_slice(e);
                    nodes.push(edge_tag[line_edges[li]]);
                    li += 1;
                }
                b.nodes = nodes;
                b.element_type = etype::LINE3;
            }
            _ => {}
        }
    }

    // periodic links: kept pairs of kept mid nodes, new pairs of new mid and face nodes
    let present: FastSet<u64> = out
        .node_blocks
        .iter()
        .flat_map(|b| b.tags.iter().copied())
        .collect();
    let edge_index: FastMap<(u64, u64), usize> = edges
        .iter()
        .enumerate()
        .map(|(i, e)| (key(e.a, e.b), i))
        .collect();
    let face_by_corners: FastMap<[u64; 4], u64> = if complete {
        quads
            .iter()
            .zip(&face_tag)
            .map(|((_, q), &t)| {
                let mut s = *q;
                s.sort_unstable();
                (s, t)
            })
            .collect()
    } else {
        FastMap::default()
    };
    for (li, link) in out.periodic.iter_mut().enumerate() {
        let map: FastMap<u64, u64> = link.node_pairs.iter().copied().collect();
        let mut pairs = link.node_pairs.clone();
        if let Some(orig) = input.periodic.get(li) {
            for &(a, b) in &orig.node_pairs {
                if !map.contains_key(&a) && present.contains(&a) && present.contains(&b) {
                    pairs.push((a, b));
                }
            }
        }
        for (e, &t) in edges.iter().zip(&edge_tag) {
            if e.owner != (link.dim, link.tag) {
                continue;
            }
            if let (Some(&ma), Some(&mb)) = (map.get(&e.a), map.get(&e.b)) {
                if let Some(&mi) = edge_index.get(&key(ma, mb)) {
                    // only a master node on the master entity
                    if edges[mi].owner == (link.dim, link.master_tag) && !map.contains_key(&t) {
                        pairs.push((t, edge_tag[mi]));
                    }
                }
            }
        }
        if complete && link.dim == 2 {
            for ((s, q), &t) in quads.iter().zip(&face_tag) {
                if *s != link.tag {
                    continue;
                }
                let mapped: Option<Vec<u64>> = q.iter().map(|c| map.get(c).copied()).collect();
                if let Some(m) = mapped {
                    let mut k = [m[0], m[1], m[2], m[3]];
                    k.sort_unstable();
                    if let Some(&mt) = face_by_corners.get(&k) {
                        pairs.push((t, mt));
                    }
                }
            }
        }
        pairs.retain(|(a, b)| present.contains(a) && present.contains(b));
        link.node_pairs = pairs;
    }

    // $NodeData that named input mid-edge nodes no longer there
    let lost = geo.mid.values().any(|m| !present.contains(m));
    if lost
        && out
            .data_sections
            .iter()
            .any(|d| d.kind == crate::mesh::DataKind::Node)
    {
        out.data_sections
            .retain(|d| d.kind != crate::mesh::DataKind::Node);
        out.warnings.push(
            "dropped the $NodeData section(s): some of their nodes (mid-edge nodes of edges the recombination removed) are gone".into(),
        );
    }

    let mut straight: Vec<u64> = straight_elems.into_iter().collect();
    straight.sort_unstable();
    report.straight = straight;
    report.invalid = bad_tags.iter().map(|b| b.2).collect();
    Ok((out, report))
}

/// Gives the mid-edge node of each input boundary edge (a 3-node line's, or a face edge
/// used once on its surface) that the linear job split (parity repair, the fallback,
/// refinement: a chain of an even number of pieces between the edge's two unmoved ends,
/// through new nodes only, along edges on the result's boundary, the edge itself gone) to
/// the chain's middle node: it takes the mid-edge node's tag and input coordinates (on the
/// curved geometry, where the linear job put it on the chord or on the curve), so the
/// input's node is the new corner. Returns the tags given. Nodes above `input_max` are the
/// linear job's new ones.
fn take_split_mid_nodes(out: &mut Mesh, geo: &Geometry, input_max: u64) -> HashSet<u64> {
    let flat = NodeTable::new(out);
    // the result's boundary edges: line elements, and quad edges used once on their
    // surface; each node's neighbours along them
    let mut edges: HashSet<(u64, u64)> = HashSet::new();
    let mut face_uses: FastMap<(i32, (u64, u64)), u32> = FastMap::default();
    for b in &out.element_blocks {
        let ring: &[usize] = match (b.entity_dim, b.element_type) {
            (2, etype::QUAD4) => &[0, 1, 2, 3],
            (1, etype::LINE2) => &[0, 1],
            _ => continue,
        };
        let k = b.nodes_per_element();
        for e in b.nodes.chunks_exact(k) {
            for (j, &i) in ring.iter().enumerate() {
                let (x, y) = (e[i], e[ring[(j + 1) % ring.len()]]);
                if x == y {
                    continue;
                }
                edges.insert(key(x, y));
                let tag = if b.entity_dim == 2 { b.entity_tag } else { -1 };
                *face_uses.entry((tag, key(x, y))).or_default() += 1;
            }
        }
    }
    let mut along: FastMap<u64, Vec<u64>> = FastMap::default();
    for (&(s, (x, y)), &n) in &face_uses {
        if s == -1 || n == 1 {
            along.entry(x).or_default().push(y);
            along.entry(y).or_default().push(x);
        }
    }
    for v in along.values_mut() {
        v.sort_unstable();
        v.dedup();
    }
    // the input's boundary edges: 3-node lines, face edges used once on their surface
    let mut boundary: HashSet<(u64, u64)> = HashSet::new();
    let mut uses: FastMap<(i32, (u64, u64)), u32> = FastMap::default();
    for b in &geo.input.element_blocks {
        let corners = match (b.entity_dim, b.element_type) {
            (1, etype::LINE3) => {
                for e in b.nodes.chunks_exact(3) {
                    boundary.insert(key(e[0], e[1]));
                }
                continue;
            }
            (2, etype::TRI6) => 3,
            (2, etype::QUAD9 | etype::QUAD8) => 4,
            _ => continue,
        };
        for e in b.nodes.chunks_exact(b.nodes_per_element()) {
            for j in 0..corners {
                *uses
                    .entry((b.entity_tag, key(e[j], e[(j + 1) % corners])))
                    .or_default() += 1;
            }
        }
    }
    boundary.extend(uses.into_iter().filter(|x| x.1 == 1).map(|x| (x.0).1));
    let present: HashSet<u64> = out
        .node_blocks
        .iter()
        .flat_map(|b| b.tags.iter().copied())
        .collect();
    // the chain of new nodes from `a` to `b` along the result's boundary (at most
    // `MAX_PIECES` pieces), its inner nodes in order
    const MAX_PIECES: usize = 64;
    let chain = |a: u64, b: u64| -> Option<Vec<u64>> {
        for &first in along.get(&a)? {
            let (mut prev, mut at) = (a, first);
            let mut inner = Vec::new();
            while at > input_max && inner.len() < MAX_PIECES {
                inner.push(at);
                // a new node on a boundary has two neighbours along it (both surfaces of
                // a shared curve see the same two)
                let next = along.get(&at).and_then(|v| {
                    let mut it = v.iter().filter(|&&x| x != prev);
                    let n = it.next().copied();
                    n.filter(|_| it.next().is_none())
                });
                let Some(next) = next else { break };
                (prev, at) = (at, next);
            }
            if at == b && !inner.is_empty() {
                return Some(inner);
            }
        }
        None
    };
    // new node -> (mid-edge node, its coordinates)
    let mut take: FastMap<u64, (u64, DVec3)> = FastMap::default();
    let mut given: HashSet<u64> = HashSet::new();
    let mut split: Vec<(u64, u64)> = boundary
        .iter()
        .copied()
        .filter(|e| !edges.contains(e))
        .collect();
    split.sort_unstable();
    for (a, b) in split {
        let Some(&m) = geo.mid.get(&key(a, b)) else {
            continue;
        };
        let (Some(xa), Some(xb), Some(xm)) = (flat.at(a), flat.at(b), geo.at(m)) else {
            continue;
        };
        // both ends where the input has them, the mid-edge node not used by the result
        if geo.at(a) != Some(xa) || geo.at(b) != Some(xb) || present.contains(&m) {
            continue;
        }
        let Some(inner) = chain(a, b) else { continue };
        if inner.len() % 2 == 0 {
            continue;
        }
        let n = inner[inner.len() / 2];
        let Some(p) = flat.at(n) else { continue };
        // the middle node between the ends: within the middle half of the chord, off it
        // by less than half its length
        let d = xb - xa;
        let u = (p - xa).dot(d) / d.length_squared();
        let between = (0.25..=0.75).contains(&u) && (p - xa - d * u).length() < 0.5 * d.length();
        if between && !take.contains_key(&n) && given.insert(m) {
            take.insert(n, (m, xm));
        }
    }
    if take.is_empty() {
        return HashSet::new();
    }
    let rename = |t: &mut u64| {
        if let Some(&(m, _)) = take.get(t) {
            *t = m;
        }
    };
    for b in &mut out.node_blocks {
        for (t, c) in b.tags.iter_mut().zip(b.coords.iter_mut()) {
            if let Some(&(m, x)) = take.get(t) {
                *t = m;
                *c = x.to_array();
            }
        }
    }
    for b in &mut out.element_blocks {
        b.nodes.iter_mut().for_each(rename);
    }
    for l in &mut out.periodic {
        for (a, b) in &mut l.node_pairs {
            rename(a);
            rename(b);
        }
    }
    out.invalidate_element_data();
    given
}

/// The chain of curve-`c` nodes from `a` to `b` through nodes `is_new` accepts, following
/// the result's line elements (`adjacency`); `None` when `a` and `b` are not joined so.
fn chain_between(
    adjacency: &FastMap<(i32, u64), Vec<u64>>,
    c: i32,
    a: u64,
    b: u64,
    is_new: &dyn Fn(u64) -> bool,
) -> Option<Vec<u64>> {
    let first = adjacency.get(&(c, a))?;
    for &n in first {
        if n == b {
            // the input segment is still one segment
            return Some(vec![a, b]);
        }
        if !is_new(n) {
            continue;
        }
        let mut chain = vec![a, n];
        let mut prev = a;
        let mut cur = n;
        loop {
            let next = adjacency
                .get(&(c, cur))
                .and_then(|v| v.iter().copied().find(|&x| x != prev));
            match next {
                Some(x) if x == b => {
                    chain.push(b);
                    return Some(chain);
                }
                Some(x) if is_new(x) && chain.len() < 1 << 12 => {
                    chain.push(x);
                    prev = cur;
                    cur = x;
                }
                _ => break,
            }
        }
    }
    None
}

/// Line3 parameters (in [-1, 1]) of the nodes of a chain from its chord-length fractions,
/// snapped to the dyadic fractions that midpoint splits make when that keeps them in order.
fn chain_parameters(pts: &[DVec3]) -> Vec<f64> {
    let mut s = vec![0.0; pts.len()];
    for k in 1..pts.len() {
        s[k] = s[k - 1] + pts[k].distance(pts[k - 1]);
    }
    let total = s.last().copied().unwrap_or(0.0);
    let n = pts.len();
    let t: Vec<f64> = if total > 0.0 {
        s.iter().map(|x| x / total).collect()
    } else {
        (0..n).map(|k| k as f64 / (n.max(2) - 1) as f64).collect()
    };
    for m in 1..=10 {
        let d = f64::from(1u32 << m);
        let snapped: Vec<f64> = t.iter().map(|x| (x * d).round() / d).collect();
        let ordered = snapped.windows(2).all(|w| w[0] < w[1]);
        let close = t
            .iter()
            .zip(&snapped)
            .all(|(x, y)| (x - y).abs() <= 0.3 / d);
        if ordered && close {
            return snapped.iter().map(|x| 2.0 * x - 1.0).collect();
        }
    }
    t.iter().map(|x| 2.0 * x - 1.0).collect()
}

/// The centre a serendipity (8-node) quad gives its middle: `Σ mid/2 − Σ corner/4`.
fn serendipity_centre(x: &[DVec3; 9]) -> DVec3 {
    (x[4] + x[5] + x[6] + x[7]) * 0.5 - (x[0] + x[1] + x[2] + x[3]) * 0.25
}

/// True when the 9-node quad `x` (an 8-node quad with its serendipity centre as node 8)
/// is valid as Gmsh measures it, and its straight-sided normal agrees with `reference`
/// (the linear quad's): every Bézier coefficient of its Jacobian determinant, measured
/// about that normal, is strictly positive. This implies a positive determinant over the
/// whole element, and it is what makes Gmsh's `minSJ` positive: Gmsh bounds the scaled
/// Jacobian from below by ratios of Bézier coefficients (degree-raised and subdivided,
/// which keeps positive coefficients positive) and reports a negative bound for valid
/// elements whose coefficients are not all positive at the depth it stops at. A
/// straight-sided quad passes exactly when its corners turn positively.
pub fn quad_valid(x: &[DVec3; 9], reference: DVec3) -> bool {
    let n = straight_normal(x);
    if n.dot(reference).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
        || x.iter().any(|p| !p.is_finite())
    {
        return false;
    }
    let n = n.normalize_or_zero();
    jacobian_positive(
        &|u, v| {
            let (xu, xv) = quad9_derivatives(x, u, v);
            xu.cross(xv).dot(n)
        },
        0,
    )
}

/// Inverse of the cubic Bernstein collocation matrix at 0, 1/3, 2/3, 1.
fn bernstein_inverse() -> [[f64; 4]; 4] {
    // M[i][j] = C(3, j) s_i^j (1 - s_i)^(3 - j)
    let binom = [1.0, 3.0, 3.0, 1.0];
    let mut m = [[0.0f64; 8]; 4];
    for (i, row) in m.iter_mut().enumerate() {
        let s = i as f64 / 3.0;
        for j in 0..4 {
            row[j] = binom[j] * s.powi(j as i32) * (1.0 - s).powi(3 - j as i32);
        }
        row[4 + i] = 1.0;
    }
    // Gauss-Jordan with partial pivoting (the matrix is well conditioned)
    for c in 0..4 {
        let p = (c..4)
            .max_by(|&a, &b| m[a][c].abs().total_cmp(&m[b][c].abs()))
            .unwrap_or(c);
        m.swap(c, p);
        let d = m[c][c];
        for v in m[c].iter_mut() {
            *v /= d;
        }
        for r in 0..4 {
            if r != c {
                let f = m[r][c];
                let pivot = m[c];
                for (v, pv) in m[r].iter_mut().zip(pivot) {
                    *v -= f * pv;
                }
            }
        }
    }
    let mut inv = [[0.0; 4]; 4];
    for i in 0..4 {
        inv[i].copy_from_slice(&m[i][4..]);
    }
    inv
}

/// True when the polynomial `f` of degree at most 3 in each of ξ, η is certified strictly
/// positive on [-1, 1]²: its Bézier coefficients on a box bound it; boxes whose
/// coefficients are not all positive are split in four, up to `max_depth` levels (then the
/// answer is `false`). With `max_depth` 0 this is the whole element's coefficients alone.
pub fn jacobian_positive(f: &dyn Fn(f64, f64) -> f64, max_depth: u32) -> bool {
    let inv = bernstein_inverse();
    let mut stack = vec![(-1.0f64, -1.0f64, 2.0f64, 0u32)];
    let mut boxes = 0;
    while let Some((u0, v0, w, depth)) = stack.pop() {
        boxes += 1;
        if boxes > 4096 {
            return false;
        }
        let mut s = [[0.0f64; 4]; 4];
        for (i, row) in s.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = f(u0 + w * i as f64 / 3.0, v0 + w * j as f64 / 3.0);
                if (*v).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                    return false;
                }
            }
        }
        // C = inv · S · invᵀ
        let mut t = [[0.0f64; 4]; 4];
        for i in 0..4 {
            for j in 0..4 {
                t[i][j] = (0..4).map(|k| inv[i][k] * s[k][j]).sum();
            }
        }
        let mut min_c = f64::INFINITY;
        for row in &t {
            for inv_j in &inv {
                let c: f64 = row.iter().zip(inv_j).map(|(a, b)| a * b).sum();
                min_c = min_c.min(c);
            }
        }
        if min_c > 0.0 {
            continue;
        }
        if depth >= max_depth {
            return false;
        }
        let h = w * 0.5;
        for (du, dv) in [(0.0, 0.0), (h, 0.0), (0.0, h), (h, h)] {
            stack.push((u0 + du, v0 + dv, h, depth + 1));
        }
    }
    true
}

/// True when the line3 `(a, b, m)` runs forward along its chord at both ends (its tangent
/// is linear in ξ, so then everywhere).
fn line_valid(a: DVec3, b: DVec3, m: DVec3) -> bool {
    let chord = b - a;
    let tangent = |xi: f64| a * (xi - 0.5) + b * (xi + 0.5) - m * (2.0 * xi);
    tangent(-1.0).dot(chord) > 0.0 && tangent(1.0).dot(chord) > 0.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::Options;

    fn square9(bulge: f64) -> [DVec3; 9] {
        let p = |x: f64, y: f64| DVec3::new(x, y, 0.0);
        [
            p(0.0, 0.0),
            p(1.0, 0.0),
            p(1.0, 1.0),
            p(0.0, 1.0),
            p(0.5, bulge),
            p(1.0, 0.5),
            p(0.5, 1.0),
            p(0.0, 0.5),
            p(0.5, 0.5 + bulge * 0.5),
        ]
    }

    #[test]
    fn straight_square_is_valid_and_scaled_jacobian_one() {
        let x = square9(0.0);
        assert!(quad_valid(&x, DVec3::Z));
        assert!((min_scaled_jacobian_at_nodes(&x) - 1.0).abs() < 1e-12);
        assert!(
            !quad_valid(&x, -DVec3::Z),
            "orientation against the reference"
        );
    }

    #[test]
    fn a_bulge_past_the_opposite_side_folds_the_quad() {
        assert!(quad_valid(&square9(0.2), DVec3::Z));
        // the bottom edge's mid node pushed above the top edge
        let x = square9(1.3);
        assert!(!quad_valid(&x, DVec3::Z));
    }

    #[test]
    fn whole_element_check_agrees_with_dense_sampling_on_random_quads() {
        // perturbed unit squares: the check must never accept a quad whose Jacobian is
        // not positive at some sample, and must accept those clearly positive everywhere
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let (mut accepted, mut refused) = (0, 0);
        for _ in 0..400 {
            let mut x = square9(0.0);
            // corners moved less than a quarter of the side keep the quad convex
            for p in x.iter_mut().take(4) {
                *p += DVec3::new(rnd(), rnd(), 0.0) * 0.45;
            }
            for p in x.iter_mut().skip(4) {
                *p += DVec3::new(rnd(), rnd(), 0.0) * 0.3;
            }
            let n = straight_normal(&x).normalize();
            let mut min = f64::INFINITY;
            for i in 0..=40 {
                for j in 0..=40 {
                    let (u, v) = (-1.0 + i as f64 / 20.0, -1.0 + j as f64 / 20.0);
                    let (xu, xv) = quad9_derivatives(&x, u, v);
                    min = min.min(xu.cross(xv).dot(n));
                }
            }
            let ok = quad_valid(&x, DVec3::Z);
            if min <= 0.0 {
                assert!(!ok, "accepted a quad with det J {min} at a sample");
            }
            // straight sides: accepted exactly when the corners turn positively
            let mut straight = x;
            for k in 0..4 {
                straight[4 + k] = (x[k] + x[(k + 1) % 4]) * 0.5;
            }
            straight[8] = serendipity_centre(&straight);
            assert!(
                quad_valid(&straight, DVec3::Z),
                "straight convex quad refused"
            );
            if ok {
                accepted += 1;
            } else {
                refused += 1;
            }
        }
        assert!(
            accepted > 20 && refused > 20,
            "{accepted} accepted, {refused} refused"
        );
    }

    #[test]
    fn bezier_bounds_agree_with_dense_sampling() {
        // f = (u - a)^2 + (v - b)^2 + c, positive iff c > 0 (for a point inside the box)
        for &(a, b, c, positive) in &[
            (0.3, -0.2, 0.01, true),
            (0.3, -0.2, -0.01, false),
            (2.0, 2.0, -1.0, true),
            (0.0, 0.0, 1e-6, true),
        ] {
            let f = |u: f64, v: f64| (u - a) * (u - a) + (v - b) * (v - b) + c;
            assert_eq!(jacobian_positive(&f, 6), positive, "a {a} b {b} c {c}");
        }
        // the whole element's coefficients alone do not certify a minimum inside it
        let f = |u: f64, v: f64| u * u + v * v + 1e-6;
        assert!(jacobian_positive(&f, 6) && !jacobian_positive(&f, 0));
    }

    #[test]
    fn tri6_and_line3_interpolate_their_nodes() {
        let x = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.1),
            DVec3::new(0.0, 1.0, 0.2),
            DVec3::new(0.5, 0.0, 0.3),
            DVec3::new(0.5, 0.5, 0.4),
            DVec3::new(0.0, 0.5, 0.5),
        ];
        assert_eq!(tri6_point(&x, [1.0, 0.0, 0.0]), x[0]);
        assert_eq!(tri6_point(&x, [0.5, 0.5, 0.0]), x[3]);
        assert_eq!(tri6_point(&x, [0.0, 0.5, 0.5]), x[4]);
        assert_eq!(tri6_point(&x, [0.5, 0.0, 0.5]), x[5]);
        let (a, b, m) = (x[0], x[1], x[3]);
        assert_eq!(line3_point(a, b, m, -1.0), a);
        assert_eq!(line3_point(a, b, m, 0.0), m);
        assert_eq!(line3_point(a, b, m, 1.0), b);
        assert!(line_valid(a, b, m));
        assert!(!line_valid(a, b, DVec3::new(1.2, 0.0, 0.0)));
    }

    #[test]
    fn chain_parameters_recover_midpoint_splits() {
        let p = |x: f64| DVec3::new(x, 0.0, 0.0);
        let xi = chain_parameters(&[p(0.0), p(0.52), p(1.0)]);
        assert_eq!(xi, vec![-1.0, 0.0, 1.0]);
        let xi = chain_parameters(&[p(0.0), p(0.24), p(0.51), p(1.0)]);
        assert_eq!(xi, vec![-1.0, -0.5, 0.0, 1.0]);
        let xi = chain_parameters(&[p(0.0), p(0.26), p(0.49), p(0.76), p(1.0)]);
        assert_eq!(xi, vec![-1.0, -0.5, 0.0, 0.5, 1.0]);
    }

    /// Two 6-node triangles making the unit square (mid-edge nodes have the largest tags,
    /// as Gmsh numbers them; the bottom edge's mid node bulges out of the plane).
    fn two_tri6() -> Mesh {
        use crate::mesh::{Entity, NodeBlock};
        let mut m = Mesh::default();
        m.entities[2].push(Entity {
            dim: 2,
            tag: 1,
            bbox: [0.0, 0.0, 0.0, 1.0, 1.0, 0.0],
            physical_tags: vec![],
            bounding: vec![],
        });
        let coords = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 0.0, 0.05], // 5: mid 1-2
            [1.0, 0.5, 0.0],  // 6: mid 2-3
            [0.5, 0.5, 0.0],  // 7: mid 3-1 (the diagonal)
            [0.5, 1.0, 0.0],  // 8: mid 3-4
            [0.0, 0.5, 0.0],  // 9: mid 4-1
        ];
        m.node_blocks.push(NodeBlock {
            entity_dim: 2,
            entity_tag: 1,
            tags: (1..=9).collect(),
            coords,
            params: None,
        });
        m.element_blocks.push(ElementBlock {
            entity_dim: 2,
            entity_tag: 1,
            element_type: etype::TRI6,
            tags: vec![1, 2],
            nodes: vec![1, 2, 3, 5, 6, 7, 1, 3, 4, 7, 8, 9],
            partitions: None,
        });
        m
    }

    #[test]
    fn linearize_checks_blocks_as_the_linear_job_does() {
        let malformed = |e: &HighOrderError| {
            matches!(
                e,
                HighOrderError::Recombine(RecombineError::MalformedBlock { .. })
            )
        };
        // a type of unknown size: kept when empty, unsupported (not malformed) otherwise
        let mut m = two_tri6();
        let unknown = ElementBlock {
            entity_dim: 2,
            entity_tag: 1,
            element_type: 1000,
            tags: vec![],
            nodes: vec![],
            partitions: None,
        };
        m.element_blocks.push(unknown.clone());
        let (lin, _) = linearize(&m, false).expect("an empty block of any type is kept");
        assert!(lin.element_blocks.iter().any(|b| b.element_type == 1000));
        m.element_blocks.pop();
        m.element_blocks.push(ElementBlock {
            tags: vec![7],
            nodes: vec![1, 2, 3],
            ..unknown
        });
        let e = linearize(&m, false).expect_err("unknown type refused");
        assert!(matches!(e, HighOrderError::Unsupported { .. }), "{e}");
        // one partition list per element, as recombination requires
        let mut m = two_tri6();
        m.element_blocks[0].partitions = Some(vec![vec![1]]);
        let e = linearize(&m, false).expect_err("partitions of one element for two");
        assert!(malformed(&e), "{e}");
        let mut m = two_tri6();
        m.element_blocks[0].nodes.pop();
        let e = linearize(&m, false).expect_err("a node short");
        assert!(malformed(&e), "{e}");
    }

    #[test]
    fn two_triangles_become_one_quad9_keeping_the_boundary_mid_nodes() {
        // numbered 1..N, the mid-edge nodes 8 and 9 would become 7 and 8 (7 is gone): the
        // tags are compared with the input's
        let mut renumbered = two_tri6();
        let plain = Options {
            optimize: false,
            ..Default::default()
        };
        crate::pipeline::quadrangulate(&mut renumbered, &plain).expect("recombined");
        let mut m = two_tri6();
        let mut opts = Options {
            optimize: false,
            keep_tags: true,
            ..Default::default()
        };
        let report = crate::pipeline::quadrangulate(&mut m, &opts).expect("recombined");
        let so = report.second_order.expect("second-order report");
        assert_eq!((so.quads, so.kept_mid_nodes, so.face_nodes), (1, 4, 1));
        let b = m
            .element_blocks
            .iter()
            .find(|b| b.entity_dim == 2)
            .expect("a surface block");
        assert_eq!(b.element_type, etype::QUAD9);
        assert_eq!(b.len(), 1);
        let e = b.element(0);
        // the four edges keep their input mid-edge nodes, the diagonal's (7) is gone, the
        // face node is new, above the input's largest tag
        let mut mids: Vec<u64> = e[4..8].to_vec();
        mids.sort_unstable();
        assert_eq!(mids, vec![5, 6, 8, 9]);
        assert!(e[8] > 9);
        let tags: Vec<u64> = m.node_blocks.iter().flat_map(|b| b.tags.clone()).collect();
        assert!(!tags.contains(&7) && tags.contains(&e[8]));
        let face = renumbered
            .element_blocks
            .iter()
            .find(|b| b.entity_dim == 2)
            .expect("a surface block")
            .element(0)
            .to_vec();
        let mut renumbered_mids: Vec<u64> = face[4..8].to_vec();
        renumbered_mids.sort_unstable();
        assert_eq!((renumbered_mids, face[8]), (vec![5, 6, 7, 8], 9));
        // the face node: the serendipity centre (0.5, 0.5, 0.025: half the bottom edge's
        // bulge) projected back onto the input surface, which is flat along the diagonal
        let index = m.node_index();
        let r = index.get(e[8]).expect("face node exists");
        let c = DVec3::from_array(m.node_blocks[r.block as usize].coords[r.index as usize]);
        assert!(c.distance(DVec3::new(0.5, 0.5, 0.0)) < 1e-12, "{c:?}");
        // --incomplete: an 8-node quad, no face node
        let mut m = two_tri6();
        opts.incomplete = true;
        crate::pipeline::quadrangulate(&mut m, &opts).expect("recombined");
        let b = m
            .element_blocks
            .iter()
            .find(|b| b.entity_dim == 2)
            .expect("block");
        assert_eq!((b.element_type, b.nodes.len()), (etype::QUAD8, 8));
    }

    #[test]
    fn quality_view_option_measures_the_second_order_result() {
        let mut m = two_tri6();
        let opts = Options {
            optimize: false,
            quality_view: true,
            ..Default::default()
        };
        crate::pipeline::quadrangulate(&mut m, &opts).expect("recombined");
        // eta, scaled jacobian, valence: once each (not also from the linear copy),
        // ASCII (the mesh has no format: MSH 4.1 ASCII by default)
        assert_eq!(m.data_sections.len(), 3);
        assert!(m
            .data_sections
            .iter()
            .all(|d| d.encoded_binary == Some(false)));
        let text = String::from_utf8_lossy(&m.data_sections[1].body).into_owned();
        assert!(text.starts_with("1\n\"scaled jacobian\""), "{text}");
        // one quad: one row, its tag and its value at the nodes
        let q = m
            .element_blocks
            .iter()
            .find(|b| b.element_type == etype::QUAD9)
            .expect("a quad9 block");
        let rows: Vec<&str> = text.lines().skip(8).collect();
        assert_eq!(rows.len(), 1, "{text}");
        let (tag, value) = rows[0].split_once(' ').expect("tag value");
        assert_eq!(tag.parse::<u64>().ok(), Some(q.tags[0]));
        let v: f64 = value.parse().expect("a number");
        assert!(v > 0.5 && v <= 1.0, "{v}");
    }

    #[test]
    fn third_order_triangles_are_refused_and_the_mesh_is_unchanged() {
        let mut m = two_tri6();
        m.element_blocks.push(ElementBlock {
            entity_dim: 2,
            entity_tag: 1,
            element_type: 21,
            tags: vec![3],
            nodes: vec![1, 2, 3, 5, 5, 6, 6, 7, 7, 8],
            partitions: None,
        });
        let before = m.clone();
        let e = crate::pipeline::quadrangulate(&mut m, &Options::default()).unwrap_err();
        assert!(e.to_string().contains("type 21"), "{e}");
        assert_eq!(m, before);
    }
}
