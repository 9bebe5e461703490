//! What the topology refuses, and folds: edges of three or more triangles, two triangles
//! running an edge the same way, and folds (walled off instead of refused).

use super::*;

/// Two adjacent triangles whose unit normals have a dot product below this are folded
/// onto each other (a turn of more than ~172° across their common edge).
pub(crate) const FOLDED: f64 = -0.99;

/// Why an edge of a surface is refused (see [`SurfaceTopo::new`]); triangles are indices
/// into the surface's triangle list.
pub(crate) enum EdgeProblem {
    /// Three or more triangles, ordered by (first node tag of their half-edge, index);
    /// `sheets` when two of them turn more than 90° from each other (sheets of the surface
    /// lying on each other, as Gmsh meshes a thin part coarser than its radius).
    NonManifold { tris: Vec<usize>, sheets: bool },
    /// Two triangles running the edge `from → to` (node tags) both.
    SameDirection {
        first: usize,
        second: usize,
        from: u64,
        to: u64,
    },
    /// Two consistently oriented triangles with opposite normals; `first` runs the edge
    /// from its lower node tag.
    Folded { first: usize, second: usize },
}

impl EdgeProblem {
    /// [`EdgeProblem::NonManifold`] of `tris`, with `sheets` when the dot product of the
    /// normals of two of them (`dot`, of two triangle indices) is negative.
    pub(crate) fn non_manifold(tris: Vec<usize>, dot: impl Fn(usize, usize) -> f64) -> Self {
        let sheets = tris.iter().any(|&t| tris.iter().any(|&u| dot(t, u) < 0.0));
        EdgeProblem::NonManifold { tris, sheets }
    }
}

/// The refusal of surface `surface` for `problem` on its edge `lo-hi` (node tags), with
/// `tag` giving the element tag of a triangle index.
pub(crate) fn edge_refusal(
    surface: i32,
    (lo, hi): (u64, u64),
    problem: EdgeProblem,
    tag: impl Fn(usize) -> u64,
) -> RecombineError {
    let (element, problem) = match problem {
        EdgeProblem::NonManifold { tris, sheets } => (
            tag(tris[2]),
            format!(
                "its edge {lo}-{hi} is shared by {} triangles of the surface (non-manifold; triangles {}, {}, ...){}",
                tris.len(),
                tag(tris[0]),
                tag(tris[1]),
                if sheets {
                    ", facing opposite ways: sheets of the surface lie on each other there, as where a thin part is meshed coarser than its radius (a finer mesh there, e.g. with Mesh.MeshSizeFromCurvature, separates them)"
                } else {
                    ""
                }
            ),
        ),
        EdgeProblem::SameDirection {
            first,
            second,
            from,
            to,
        } => (
            tag(second),
            format!(
                "the triangle runs its edge {from}-{to} in the same direction as triangle {} (inconsistent orientation: one of them is flipped, or they overlap)",
                tag(first)
            ),
        ),
        EdgeProblem::Folded { first, second } => (
            tag(second),
            format!(
                "the triangle is folded over triangle {} across their common edge {lo}-{hi} (their normals point in opposite directions: overlapping or inverted triangles)",
                tag(first)
            ),
        ),
    };
    RecombineError::InvalidElement {
        surface,
        element,
        problem,
    }
}

/// The problem of the edge whose half-edges are `run`: three or more of them, or two
/// running the edge the same way; with the edge's node tags (lower, higher). `normals`:
/// the triangles' unit normals.
pub(super) fn structural_problem(
    run: &[u32],
    tris: &[[u32; 3]],
    normals: &[glam::DVec3],
    nodes: &NodeTable,
) -> ((u64, u64), EdgeProblem) {
    // (first node, second node) of the half-edge, as tags, and its triangle
    let half = |h: u32| {
        let (t, k) = (h as usize / 3, h as usize % 3);
        let (a, b) = (tris[t][k], tris[t][(k + 1) % 3]);
        (nodes.tags[a as usize], nodes.tags[b as usize], t)
    };
    let (a, b, t0) = half(run[0]);
    let key = (a.min(b), a.max(b));
    if run.len() > 2 {
        let mut ts: Vec<(u64, usize)> = run.iter().map(|&h| half(h)).map(|x| (x.0, x.2)).collect();
        ts.sort_unstable();
        let tris = ts.into_iter().map(|x| x.1).collect();
        let problem = EdgeProblem::non_manifold(tris, |t, u| normals[t].dot(normals[u]));
        return (key, problem);
    }
    let t1 = run[1] as usize / 3;
    let (first, second) = (t0.min(t1), t0.max(t1));
    (
        key,
        EdgeProblem::SameDirection {
            first,
            second,
            from: a,
            to: b,
        },
    )
}

/// The fold with the smallest edge (node tags) among the consistently oriented neighbours:
/// the graph edges of `nbr` and the `walled` half-edge pairs (neighbours across a curve).
pub(super) fn first_fold(
    tris: &[[u32; 3]],
    normals: &[glam::DVec3],
    nbr: &[u32],
    walled: &[(u32, u32)],
    nodes: &NodeTable,
) -> Option<((u64, u64), EdgeProblem)> {
    // the fold of half-edge `h` of triangle t and its neighbour u, with the edge's tags
    let fold = |h: usize, t: usize, u: usize| {
        (normals[t].dot(normals[u]) < FOLDED).then(|| {
            let (a, b) = (tris[t][h % 3], tris[t][(h % 3 + 1) % 3]);
            let (a, b) = (nodes.tags[a as usize], nodes.tags[b as usize]);
            // the triangle running the edge from its lower tag first
            let (first, second) = if a < b { (t, u) } else { (u, t) };
            ((a.min(b), a.max(b)), first, second)
        })
    };
    let graph = (0..tris.len())
        .into_par_iter()
        .with_min_len(4096)
        .filter_map(|t| {
            (3 * t..3 * t + 3)
                .filter(|&h| nbr[h] != NONE && nbr[h] as usize > t)
                .filter_map(|h| fold(h, t, nbr[h] as usize))
                .min()
        })
        .min();
    let curve = walled
        .iter()
        .filter_map(|&(h0, h1)| {
            let (t, u) = (h0 as usize / 3, h1 as usize / 3);
            fold(h0 as usize, t, u)
        })
        .min();
    graph
        .into_iter()
        .chain(curve)
        .min()
        .map(|(key, first, second)| (key, EdgeProblem::Folded { first, second }))
}

/// Makes every graph edge of `nbr` across which two triangles are folded (unit normals'
/// dot product below [`FOLDED`]) a wall: both half-edges get [`NONE`]. Returns the nodes of
/// those edges (sorted global ids).
pub(super) fn wall_folds(tris: &[[u32; 3]], normals: &[glam::DVec3], nbr: &mut [u32]) -> Vec<u32> {
    let folded: Vec<usize> = (0..nbr.len())
        .into_par_iter()
        .with_min_len(4096)
        .filter(|&h| {
            let u = nbr[h];
            u != NONE && normals[h / 3].dot(normals[u as usize]) < FOLDED
        })
        .collect();
    let mut ends = Vec::with_capacity(2 * folded.len());
    for h in folded {
        nbr[h] = NONE;
        let (t, k) = (h / 3, h % 3);
        ends.push(tris[t][k]);
        ends.push(tris[t][(k + 1) % 3]);
    }
    ends.sort_unstable();
    ends.dedup();
    ends
}
