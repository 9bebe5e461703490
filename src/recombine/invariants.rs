//! Invariants of recombination, checked from the two meshes alone. Deliberately simple
//! (sorted edge lists keyed by node tags, one surface at a time) and sharing no code with
//! the recombination itself. It runs on every `quadrangulate` call, so it is linear: its
//! sorts are radix sorts of packed tag pairs (`crate::keysort`), and it is parallel over
//! surfaces (and over its independent sorts within one).

use rayon::prelude::*;

use crate::keysort::sort_pairs;
use crate::mesh::{element_dim, etype, Mesh, TagCoords};

type Edge = (u64, u64);

/// Faces per parallel task within one surface.
const CHUNK: usize = 8192;

fn undirected(a: u64, b: u64) -> Edge {
    (a.min(b), a.max(b))
}

fn has(sorted: &[Edge], e: &Edge) -> bool {
    sorted.binary_search(e).is_ok()
}

/// Corner nodes of the 2D elements (tri3, quad4) of one surface.
fn faces_of(mesh: &Mesh, surface: i32) -> Vec<&[u64]> {
    let mut out = Vec::new();
    for b in &mesh.element_blocks {
        if b.entity_dim != 2 || b.entity_tag != surface || element_dim(b.element_type) != Some(2) {
            continue;
        }
        if b.element_type != etype::TRI3 && b.element_type != etype::QUAD4 {
            continue;
        }
        for i in 0..b.len() {
            out.push(b.element(i));
        }
    }
    out
}

/// Every undirected edge of `faces` with the number of faces using it, sorted.
fn edge_counts(faces: &[&[u64]]) -> Vec<(Edge, u32)> {
    let mut all: Vec<Edge> = Vec::with_capacity(faces.iter().map(|f| f.len()).sum());
    for f in faces {
        for i in 0..f.len() {
            all.push(undirected(f[i], f[(i + 1) % f.len()]));
        }
    }
    sort_pairs(&mut all);
    // memory: sized exactly (see `EdgeTable::new`)
    let distinct = 1 + all.windows(2).filter(|w| w[0] != w[1]).count();
    let mut out: Vec<(Edge, u32)> = Vec::with_capacity(distinct);
    for e in all {
        match out.last_mut() {
            Some((last, c)) if *last == e => *c += 1,
            _ => out.push((e, 1)),
        }
    }
    out
}

fn count_of(counts: &[(Edge, u32)], e: &Edge) -> u32 {
    counts
        .binary_search_by_key(e, |x| x.0)
        .map_or(0, |i| counts[i].1)
}

/// The uses of face `f`'s edges as (smaller node, larger node · 2 + 1 when the face runs
/// the edge from the larger).
fn edge_uses(f: &[u64]) -> impl Iterator<Item = Edge> + '_ {
    (0..f.len()).map(move |i| {
        let (a, b) = (f[i], f[(i + 1) % f.len()]);
        let (lo, hi) = undirected(a, b);
        (lo, (hi << 1) | u64::from(a > b))
    })
}

/// The edges of `faces` with how many faces use each and in which directions, sorted by
/// edge, with (when node tags are compact) the start of each first node's run, so that a
/// lookup is two nearby reads instead of a binary search over the whole list.
///
/// Memory (it is held through the whole run): the fields are parallel arrays, and with the
/// runs the first node of an entry is its run's, not stored: 12 bytes an edge instead of a
/// tuple's 24.
struct EdgeTable {
    /// Smaller node of each edge; empty when `start` is not (the entry's run tells it).
    lo: Vec<u64>,
    /// Larger node of each edge.
    hi: Vec<u64>,
    /// Faces using the edge (saturating) · 4, plus bit 0: some face runs it from its
    /// smaller node, bit 1: some face runs it from its larger node.
    uses: Vec<u32>,
    /// Entries of first node `a`: `start[a]..start[a + 1]`; empty when tags are not
    /// compact.
    start: Vec<u32>,
}

impl EdgeTable {
    /// Largest face count stored (a count only ever compared with 1 and 2).
    const MAX_COUNT: u32 = u32::MAX >> 2;

    fn new(faces: &[&[u64]]) -> Self {
        let n_uses: usize = faces.iter().map(|f| f.len()).sum();
        let max = faces.iter().flat_map(|f| f.iter()).copied().max();
        match max {
            Some(max) if max <= 4 * n_uses as u64 + 1024 => Self::with_runs(faces, max, n_uses),
            _ => Self::sorted(faces, n_uses),
        }
    }

    /// The table of `faces` whose node tags are at most `max`, compact enough for runs.
    ///
    /// Memory (this is built beside the optimizer): each use goes straight into its smaller
    /// node's run (a counting sort, one `u64` a use), each run is sorted on its own and its
    /// repeated edges merged, so the construction needs about a quarter of the memory of a
    /// sort of `(smaller, larger)` pairs with its scratch.
    fn with_runs(faces: &[&[u64]], max: u64, n_uses: usize) -> Self {
        let mut start = vec![0u32; max as usize + 2];
        for f in faces {
            for (lo, _) in edge_uses(f) {
                start[lo as usize + 1] += 1;
            }
        }
        for i in 1..start.len() {
            start[i] += start[i - 1];
        }
        // filling moves each run's start to the next run's; shifted back below
        let mut x = vec![0u64; n_uses];
        for f in faces {
            for (lo, key) in edge_uses(f) {
                let lo = lo as usize;
                x[start[lo] as usize] = key;
                start[lo] += 1;
            }
        }
        let len = start.len();
        start.copy_within(0..len - 1, 1);
        start[0] = 0;
        let run = |a: usize| start[a] as usize..start[a + 1] as usize;
        for a in 0..start.len() - 1 {
            x[run(a)].sort_unstable();
        }
        // memory: sized exactly
        let distinct = (0..start.len() - 1)
            .map(|a| {
                let r = &x[run(a)];
                usize::from(!r.is_empty()) + r.windows(2).filter(|w| w[0] >> 1 != w[1] >> 1).count()
            })
            .sum();
        let mut hi: Vec<u64> = Vec::with_capacity(distinct);
        let mut uses: Vec<u32> = Vec::with_capacity(distinct);
        // each run's start becomes its first distinct edge's (read before it is rewritten)
        let mut begin = 0usize;
        for a in 0..start.len() - 1 {
            let end = start[a + 1] as usize;
            start[a] = hi.len() as u32;
            let mut open = false;
            for &k in &x[begin..end] {
                Self::add_use(&mut hi, &mut uses, &mut open, k);
            }
            begin = end;
        }
        let last = start.len() - 1;
        start[last] = hi.len() as u32;
        EdgeTable {
            lo: Vec::new(),
            hi,
            uses,
            start,
        }
    }

    /// Adds use `key` (larger node · 2 + runs from the larger) of the current first node:
    /// to the last edge when `open` and it is the same edge, else as a new edge.
    fn add_use(hi: &mut Vec<u64>, uses: &mut Vec<u32>, open: &mut bool, key: u64) {
        let b = key >> 1;
        let dir = 1u32 << (key & 1);
        match (hi.last(), uses.last_mut()) {
            (Some(&lb), Some(u)) if *open && lb == b => {
                let count = (*u >> 2).saturating_add(1).min(Self::MAX_COUNT);
                *u = (count << 2) | (*u & 3) | dir;
            }
            _ => {
                hi.push(b);
                uses.push((1 << 2) | dir);
                *open = true;
            }
        }
    }

    /// The table of `faces` with sparse node tags: one sort of the uses, lookups by binary
    /// search.
    fn sorted(faces: &[&[u64]], n_uses: usize) -> Self {
        // each use as (smaller node, larger node · 2 + runs from the larger): one sort gives
        // the counts and the directions
        let mut all: Vec<Edge> = Vec::with_capacity(n_uses);
        for f in faces {
            all.extend(edge_uses(f));
        }
        sort_pairs(&mut all);
        // memory: sized exactly (a guess of half the uses is one short on any surface with
        // a boundary, and the growth doubles it)
        let distinct = 1 + all
            .windows(2)
            .filter(|w| (w[0].0, w[0].1 >> 1) != (w[1].0, w[1].1 >> 1))
            .count();
        let mut lo: Vec<u64> = Vec::with_capacity(distinct);
        let mut hi: Vec<u64> = Vec::with_capacity(distinct);
        let mut uses: Vec<u32> = Vec::with_capacity(distinct);
        for (a, key) in all {
            // the same edge as the last one only within the same first node
            let mut open = lo.last() == Some(&a);
            let before = hi.len();
            Self::add_use(&mut hi, &mut uses, &mut open, key);
            if hi.len() > before {
                lo.push(a);
            }
        }
        EdgeTable {
            lo,
            hi,
            uses,
            start: Vec::new(),
        }
    }

    /// The `uses` entry of undirected edge `e`.
    fn find(&self, e: &Edge) -> Option<u32> {
        let (a, b) = *e;
        if self.start.is_empty() {
            // sorted by (lo, hi): the run of `a` by binary search, then `b` inside it
            let from = self.lo.partition_point(|&x| x < a);
            let to = from + self.lo[from..].partition_point(|&x| x == a);
            return self.hi[from..to]
                .binary_search(&b)
                .ok()
                .map(|i| self.uses[from + i]);
        }
        match (self.start.get(a as usize), self.start.get(a as usize + 1)) {
            (Some(&from), Some(&to)) => {
                let (from, to) = (from as usize, to as usize);
                self.hi[from..to]
                    .iter()
                    .position(|&x| x == b)
                    .map(|i| self.uses[from + i])
            }
            _ => None,
        }
    }

    /// Faces using undirected edge `e`.
    fn count(&self, e: &Edge) -> u32 {
        self.find(e).map_or(0, |u| u >> 2)
    }

    /// Some face runs the edge from `p` to `q`.
    fn runs(&self, p: u64, q: u64) -> bool {
        let bit = if p < q { 1 } else { 2 };
        self.find(&undirected(p, q)).is_some_and(|u| u & bit != 0)
    }

    /// The edges used by one face, sorted.
    fn boundary(&self) -> Vec<Edge> {
        let once = |i: usize| self.uses[i] >> 2 == 1;
        if self.start.is_empty() {
            return (0..self.hi.len())
                .filter(|&i| once(i))
                .map(|i| (self.lo[i], self.hi[i]))
                .collect();
        }
        let mut out = Vec::new();
        for (a, w) in self.start.windows(2).enumerate() {
            out.extend(
                (w[0] as usize..w[1] as usize)
                    .filter(|&i| once(i))
                    .map(|i| (a as u64, self.hi[i])),
            );
        }
        out
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Twice the vector area of a polygon (sum of `p_i × p_{i+1}` about its first vertex).
fn vector_area(poly: &[[f64; 3]]) -> [f64; 3] {
    let mut s = [0.0; 3];
    for i in 1..poly.len().saturating_sub(1) {
        let c = cross(sub(poly[i], poly[0]), sub(poly[i + 1], poly[0]));
        for k in 0..3 {
            s[k] += c[k];
        }
    }
    s
}

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

/// What [`check_invariants`] found broken, with the entities and nodes involved. Its text
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
    /// An edge of `after` is neither an edge of `before` nor half of one split at a new
    /// node.
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
///   have been split in two at a new node (parity repair); every 2-node line element of
///   `after` is a line element of `before` or one half of such a split;
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

/// Twice the summed vector area of `faces` of `m` (by chunks of faces in parallel added in
/// order: the same sum for any thread count); the first face with an unknown node is an
/// error.
fn area(
    faces: &[&[u64]],
    idx: &TagCoords,
    s: i32,
    input: bool,
) -> Result<[f64; 3], InvariantViolation> {
    // faces have 3 or 4 nodes: no allocation per face
    let pts4 = |f: &[u64]| -> Option<([[f64; 3]; 4], usize)> {
        let mut p = [[0.0; 3]; 4];
        for (x, &t) in p.iter_mut().zip(f) {
            *x = idx.get(t)?;
        }
        Some((p, f.len().min(4)))
    };
    let parts: Vec<Result<[f64; 3], InvariantViolation>> = faces
        .par_chunks(CHUNK)
        .map(|c| {
            let mut t = [0.0; 3];
            for f in c {
                let p = pts4(f).ok_or_else(|| InvariantViolation::UnknownNode {
                    surface: s,
                    input,
                    nodes: f.to_vec(),
                })?;
                let a = vector_area(&p.0[..p.1]);
                for k in 0..3 {
                    t[k] += a[k];
                }
            }
            Ok(t)
        })
        .collect();
    let mut total = [0.0; 3];
    for p in parts {
        let p = p?;
        for k in 0..3 {
            total[k] += p[k];
        }
    }
    Ok(total)
}

impl SurfaceBefore {
    fn new(before: &Mesh, ib: &TagCoords, s: i32) -> Self {
        let faces = faces_of(before, s);
        let (edges, total) = rayon::join(|| EdgeTable::new(&faces), || area(&faces, ib, s, true));
        let boundary = edges.boundary();
        let plane = total
            .as_ref()
            .ok()
            .and_then(|&total| plane_of(ib, &faces, total));
        SurfaceBefore {
            edges,
            boundary,
            total,
            plane,
        }
    }
}

/// The edges of `counts` used by one face.
fn boundary(counts: &[(Edge, u32)]) -> Vec<Edge> {
    counts
        .iter()
        .filter(|(_, c)| *c == 1)
        .map(|(e, _)| *e)
        .collect()
}

/// The unit normal `total` of `faces` when they are planar: every corner within 1e-10 of
/// the extent (the largest distance from the first corner) of the plane through the first
/// corner. `None` when they are not, or `total` is zero.
fn plane_of(ib: &TagCoords, faces: &[&[u64]], total: [f64; 3]) -> Option<[f64; 3]> {
    let norm = dot(total, total).sqrt();
    if norm == 0.0 {
        return None;
    }
    let n = total.map(|x| x / norm);
    let o = faces
        .first()
        .and_then(|f| f.first())
        .and_then(|&t| ib.get(t))
        .unwrap_or([0.0; 3]);
    // (extent, largest distance from the plane, a distance that is not a number)
    let spread = |c: &[&[u64]]| {
        let mut r = (0.0_f64, 0.0_f64, false);
        for p in c.iter().flat_map(|f| f.iter().filter_map(|&t| ib.get(t))) {
            let d = sub(p, o);
            r.0 = r.0.max(dot(d, d).sqrt());
            let off = dot(d, n).abs();
            r.1 = r.1.max(off);
            r.2 |= off.is_nan();
        }
        r
    };
    let (extent, off, nan) = faces.par_chunks(CHUNK).map(spread).reduce(
        || (0.0, 0.0, false),
        |a, b| (a.0.max(b.0), a.1.max(b.1), a.2 || b.2),
    );
    (!nan && off <= 1e-10 * extent.max(f64::MIN_POSITIVE)).then_some(n)
}

/// The per-surface part of [`check_invariants`].
fn check_surface(
    before: &Before,
    sb: &SurfaceBefore,
    after: &Mesh,
    ia: &TagCoords,
    s: i32,
) -> Result<(), InvariantViolation> {
    let ib = &before.index;
    let new_node = |t: u64| ib.get(t).is_none();
    let fa = faces_of(after, s);
    if let Some(f) = fa
        .iter()
        .find(|f| (1..f.len()).any(|j| f[..j].contains(&f[j])))
    {
        return Err(InvariantViolation::RepeatedNode {
            surface: s,
            nodes: f.to_vec(),
        });
    }
    let eb = &sb.edges;
    let ea = edge_counts(&fa);
    if let Some((e, c)) = ea.iter().find(|(e, c)| *c > 2 && eb.count(e) <= 2) {
        return Err(InvariantViolation::EdgeShared {
            surface: s,
            edge: *e,
            faces: *c,
        });
    }
    let ba = boundary(&ea);
    check_split_sets(
        &sb.boundary,
        &ba,
        &new_node,
        EdgeSet::Boundary { surface: s },
    )?;
    // curve segments of `before` that are no longer edges must be split in two at a new
    // node (found through the nodes next to each node along the edges of `after`, built
    // only when some segment is missing)
    let missing: Vec<&Edge> = before
        .lines
        .iter()
        .filter(|e| eb.count(e) > 0 && count_of(&ea, e) == 0)
        .collect();
    if !missing.is_empty() {
        let mut nbr: Vec<Edge> = Vec::with_capacity(2 * ea.len());
        for ((x, y), _) in &ea {
            nbr.push((*x, *y));
            nbr.push((*y, *x));
        }
        sort_pairs(&mut nbr);
        let split_present = |e: &Edge| -> bool {
            let from = nbr.partition_point(|x| x.0 < e.0);
            nbr[from..]
                .iter()
                .take_while(|x| x.0 == e.0)
                .any(|&(_, m)| new_node(m) && count_of(&ea, &undirected(m, e.1)) > 0)
        };
        if let Some(e) = missing.into_iter().find(|e| !split_present(e)) {
            return Err(InvariantViolation::CurveSegmentLost {
                surface: s,
                segment: *e,
            });
        }
    }
    // orientation (faces in parallel; the first offending face in order is reported)
    let against = |f: &[u64]| -> Option<Edge> {
        (0..f.len())
            .map(|i| (f[i], f[(i + 1) % f.len()]))
            .find(|&(p, q)| eb.runs(q, p) && !eb.runs(p, q))
    };
    if let Some((f, (p, q))) = fa
        .par_iter()
        .with_min_len(CHUNK)
        .find_map_first(|f| against(f).map(|e| (f, e)))
    {
        return Err(InvariantViolation::Orientation {
            surface: s,
            nodes: f.to_vec(),
            edge: (p, q),
        });
    }
    // planar area
    let total = sb.total.clone()?;
    let Some(n) = sb.plane else {
        return Ok(());
    };
    let area_after = dot(area(&fa, ia, s, false)?, n);
    let area_before = dot(total, n);
    if ((area_after - area_before) / area_before).abs() > 1e-9 {
        return Err(InvariantViolation::AreaChanged {
            surface: s,
            before: area_before / 2.0,
            after: area_after / 2.0,
        });
    }
    Ok(())
}

/// `after` equals `before` where some edges `{a, b}` are replaced by `{a, m}`, `{m, b}` with
/// `m` a new node. Both lists sorted and deduplicated.
fn check_split_sets(
    before: &[Edge],
    after: &[Edge],
    new_node: &dyn Fn(u64) -> bool,
    set: EdgeSet,
) -> Result<(), InvariantViolation> {
    // the halves, as (new node, far end), sorted: pairs of them rebuild a split edge
    let mut halves: Vec<(u64, u64)> = Vec::new();
    for &(x, y) in after.iter().filter(|e| !has(before, e)) {
        match (new_node(x), new_node(y)) {
            (true, false) => halves.push((x, y)),
            (false, true) => halves.push((y, x)),
            _ => return Err(InvariantViolation::NewEdge { set, edge: (x, y) }),
        }
    }
    halves.sort_unstable();
    let mut rebuilt: Vec<Edge> = Vec::with_capacity(halves.len() / 2);
    let mut i = 0;
    while i < halves.len() {
        let m = halves[i].0;
        let j = halves[i..].partition_point(|h| h.0 == m) + i;
        if j - i != 2 {
            return Err(InvariantViolation::SplitNode {
                set,
                node: m,
                halves: j - i,
            });
        }
        rebuilt.push(undirected(halves[i].1, halves[i + 1].1));
        i = j;
    }
    rebuilt.sort_unstable();
    let mut used = vec![false; rebuilt.len()];
    for e in before.iter().filter(|e| !has(after, e)) {
        // a split edge may be rebuilt once
        let from = rebuilt.partition_point(|r| r < e);
        match (from..rebuilt.len()).find(|&k| rebuilt[k] == *e && !used[k]) {
            Some(k) => used[k] = true,
            None => return Err(InvariantViolation::EdgeDisappeared { set, edge: *e }),
        }
    }
    if let Some(k) = used.iter().position(|u| !u) {
        let e = rebuilt[k];
        return Err(InvariantViolation::UnknownSplit { set, edge: e });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::testing::{node_block, one_surface};

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
