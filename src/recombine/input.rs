//! Element-level input checks run before any recombination work: surface elements that no
//! recombination can turn into valid quads are refused with the surface, the element tag
//! and the reason, instead of producing a broken mesh (classes found by fuzzing the
//! pipeline, see `fuzz/`):
//!
//! - a triangle or quad that names the same node twice;
//! - a node of a surface element with a non-finite coordinate, or one so large that
//!   products of coordinate differences overflow ([`MAX_COORDINATE`]);
//! - a triangle of zero area (its nodes coincide or are collinear, to rounding);
//! - two triangles with the same three nodes;
//! - an edge shared by three or more triangles of one surface (non-manifold: a parity
//!   split of it gives edges that no conforming recombination has);
//! - two triangles running their common edge in the same direction (inconsistent
//!   orientation: a flipped or overlapping triangle; the optimizer would move the nodes
//!   of such an edge as if the surface continued across it);
//! - a fold: two triangles sharing an edge, consistently oriented, whose normals point
//!   in opposite directions (one is flipped over the other; on a planar surface, an
//!   inverted triangle).

use rayon::prelude::*;

use super::RecombineError;
use crate::keysort::{bits, bucket_sort, sort_by_prefix};
use crate::mesh::{etype, Mesh};

/// Largest accepted coordinate magnitude of a surface element's node. Quality measures
/// multiply up to four coordinate differences; beyond this they overflow to infinity.
pub(crate) const MAX_COORDINATE: f64 = 1e60;

/// Below this `|(b − a) × (c − a)| / (|ab|² + |bc|² + |ca|²)` a triangle has no area to
/// rounding (an equilateral triangle has √3/6 ≈ 0.29; a needle of height `h` and length
/// `L` about `h / 2L`; slivers of a graded Delaunay mesh reach 5.7·10⁻¹⁴ in
/// `tests/recombine_random.rs` and are kept).
const ZERO_AREA: f64 = 1e-15;

/// Two adjacent triangles whose unit normals have a dot product below this are folded
/// onto each other (a turn of more than ~172° across their common edge).
const FOLDED: f64 = -0.99;

type V = [f64; 3];

fn sub(a: V, b: V) -> V {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: V, b: V) -> V {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: V, b: V) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn invalid(surface: i32, element: u64, problem: String) -> RecombineError {
    RecombineError::InvalidElement {
        surface,
        element,
        problem,
    }
}

/// Largest node or element tag accepted: new nodes and elements (parity splits, vertex
/// duplications, refinement) are numbered above the largest tag, which must not overflow.
pub(crate) const MAX_TAG: u64 = 1 << 62;

/// Refuses node and element tags above [`MAX_TAG`] (a fuzz finding: a tag of 2⁶⁴ − 1 made
/// the first new tag overflow).
pub(crate) fn check_tag_room(mesh: &Mesh) -> Result<(), RecombineError> {
    for (what, tag) in [
        ("node", mesh.max_node_tag()),
        ("element", mesh.max_element_tag()),
    ] {
        if tag > MAX_TAG {
            return Err(RecombineError::TagTooLarge {
                what,
                tag,
                max: MAX_TAG,
            });
        }
    }
    Ok(())
}

/// Checks every 3-node triangle and 4-node quad of every surface (see the module doc).
/// Unknown nodes are left to the later stages, which name them.
pub(crate) fn check_surface_elements(mesh: &Mesh) -> Result<(), RecombineError> {
    let index = mesh.node_index();
    let coord = |tag: u64| -> Option<V> {
        let r = index.get(tag)?;
        let b = mesh.node_blocks.get(r.block as usize)?;
        b.coords.get(r.index as usize).copied()
    };
    let mut surfaces: Vec<i32> = mesh
        .element_blocks
        .iter()
        .filter(|b| {
            b.entity_dim == 2 && (b.element_type == etype::TRI3 || b.element_type == etype::QUAD4)
        })
        .map(|b| b.entity_tag)
        .collect();
    surfaces.sort_unstable();
    surfaces.dedup();
    surfaces
        .par_iter()
        .map(|&s| check_surface(mesh, s, &coord))
        .collect::<Result<Vec<()>, _>>()
        .map(|_| ())
}

fn check_surface(
    mesh: &Mesh,
    surface: i32,
    coord: &(dyn Fn(u64) -> Option<V> + Sync),
) -> Result<(), RecombineError> {
    // triangles with their normals, for the duplicate and fold checks
    let mut tris: Vec<([u64; 3], u64, V)> = Vec::new();
    for b in mesh.element_blocks.iter().filter(|b| {
        b.entity_dim == 2
            && b.entity_tag == surface
            && (b.element_type == etype::TRI3 || b.element_type == etype::QUAD4)
    }) {
        let k = if b.element_type == etype::TRI3 { 3 } else { 4 };
        'elements: for i in 0..b.len() {
            let nodes = &b.element(i)[..k];
            let tag = b.tags[i];
            for (j, &v) in nodes.iter().enumerate() {
                if nodes[..j].contains(&v) {
                    return Err(invalid(
                        surface,
                        tag,
                        format!(
                            "it names node {v} twice; a {} needs {k} distinct nodes",
                            if k == 3 { "triangle" } else { "quad" }
                        ),
                    ));
                }
            }
            let mut p = [[0.0; 3]; 4];
            for (j, &v) in nodes.iter().enumerate() {
                let Some(c) = coord(v) else {
                    // unknown node: reported by the topology stage
                    continue 'elements;
                };
                if let Some(x) = c
                    .iter()
                    .find(|x| !x.is_finite() || x.abs() > MAX_COORDINATE)
                {
                    return Err(invalid(
                        surface,
                        tag,
                        if x.is_finite() {
                            format!(
                                "its node {v} has a coordinate {x:e}, beyond the supported magnitude {MAX_COORDINATE:e}"
                            )
                        } else {
                            format!("its node {v} has a coordinate that is not a finite number")
                        },
                    ));
                }
                p[j] = c;
            }
            if k == 3 {
                let n = cross(sub(p[1], p[0]), sub(p[2], p[0]));
                let scale = dot(sub(p[1], p[0]), sub(p[1], p[0]))
                    + dot(sub(p[2], p[1]), sub(p[2], p[1]))
                    + dot(sub(p[0], p[2]), sub(p[0], p[2]));
                let area2 = dot(n, n).sqrt();
                if area2.is_nan() || area2 <= ZERO_AREA * scale {
                    return Err(invalid(
                        surface,
                        tag,
                        format!(
                            "the triangle has no area (its nodes {}, {}, {} coincide or are collinear to {:.1e} of its size)",
                            nodes[0],
                            nodes[1],
                            nodes[2],
                            area2 / scale
                        ),
                    ));
                }
                let unit = n.map(|x| x / area2);
                tris.push(([nodes[0], nodes[1], nodes[2]], tag, unit));
            }
        }
    }
    // duplicates: triangles sorted by their sorted node triple
    let mut sets: Vec<([u64; 3], u32)> = tris
        .iter()
        .enumerate()
        .map(|(t, (v, _, _))| {
            let mut s = *v;
            s.sort_unstable();
            (s, t as u32)
        })
        .collect();
    // speed: a bucket sort by the smallest tag, else radix sorted on the packed triple when
    // it fits in 64 bits (same order)
    let b = bits(sets.iter().map(|x| x.0[2]).max().unwrap_or(0));
    if !bucket_sort(&mut sets, |x| x.0[0]) {
        if 3 * b < u64::BITS {
            sort_by_prefix(&mut sets, |x| (x.0[0] << (2 * b)) | (x.0[1] << b) | x.0[2]);
        } else {
            sets.sort_unstable();
        }
    }
    if let Some(w) = sets.windows(2).find(|w| w[0].0 == w[1].0) {
        let (s, a, b) = (w[0].0, &tris[w[0].1 as usize], &tris[w[1].1 as usize]);
        return Err(invalid(
            surface,
            b.1,
            format!(
                "the triangle has the same nodes {}, {}, {} as triangle {}",
                s[0], s[1], s[2], a.1
            ),
        ));
    }
    // folds: half-edges (from, to, triangle) sorted by undirected edge; an edge of exactly
    // two triangles that run through it in opposite directions (consistently oriented
    // neighbours) whose normals point opposite ways
    let mut half: Vec<(u64, u64, u64, u32)> = Vec::with_capacity(3 * tris.len());
    for (t, (v, _, _)) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (v[k], v[(k + 1) % 3]);
            half.push((a.min(b), a.max(b), a, t as u32));
        }
    }
    // speed: a bucket sort by the edge's first tag, else radix sorted on the packed edge
    // when it fits in 64 bits (same order)
    let b = bits(half.iter().map(|x| x.1).max().unwrap_or(0));
    if !bucket_sort(&mut half, |x| x.0) {
        if 2 * b < u64::BITS {
            sort_by_prefix(&mut half, |x| (x.0 << b) | x.1);
        } else {
            half.sort_unstable();
        }
    }
    let mut i = 0;
    while i < half.len() {
        let mut j = i + 1;
        while j < half.len() && half[j].0 == half[i].0 && half[j].1 == half[i].1 {
            j += 1;
        }
        let run = &half[i..j];
        if run.len() > 2 {
            let t = &tris[run[2].3 as usize];
            return Err(invalid(
                surface,
                t.1,
                format!(
                    "its edge {}-{} is shared by {} triangles of the surface (non-manifold; triangles {}, {}, ...)",
                    run[0].0,
                    run[0].1,
                    run.len(),
                    tris[run[0].3 as usize].1,
                    tris[run[1].3 as usize].1
                ),
            ));
        }
        if let [a, b] = run {
            let (ta, tb) = (&tris[a.3 as usize], &tris[b.3 as usize]);
            if a.2 == b.2 {
                return Err(invalid(
                    surface,
                    tb.1,
                    format!(
                        "the triangle runs its edge {}-{} in the same direction as triangle {} (inconsistent orientation: one of them is flipped, or they overlap)",
                        a.2,
                        if a.2 == a.0 { a.1 } else { a.0 },
                        ta.1
                    ),
                ));
            }
            if a.2 != b.2 && dot(ta.2, tb.2) < FOLDED {
                return Err(invalid(
                    surface,
                    tb.1,
                    format!(
                        "the triangle is folded over triangle {} across their common edge {}-{} (their normals point in opposite directions: overlapping or inverted triangles)",
                        ta.1, a.0, a.1
                    ),
                ));
            }
        }
        i = j;
    }
    Ok(())
}
