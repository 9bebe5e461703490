//! Element-level input checks run before any recombination work: surface elements that no
//! recombination can turn into valid quads are refused with the surface, the element tag
//! and the reason, instead of producing a broken mesh (classes found by fuzzing the
//! pipeline, see `fuzz/`):
//!
//! - a triangle or quad that names the same node twice;
//! - a node of a surface element with a non-finite coordinate, or one so large that
//!   products of coordinate differences overflow ([`MAX_COORDINATE`]);
//! - a triangle of zero area (its nodes coincide or are collinear, to rounding);
//! - an edge shared by three or more triangles of one surface (non-manifold: a parity
//!   split of it gives edges that no conforming recombination has);
//! - two triangles running their common edge in the same direction (inconsistent
//!   orientation: a flipped or overlapping triangle; the optimizer would move the nodes
//!   of such an edge as if the surface continued across it);
//! - a fold: two triangles sharing an edge, consistently oriented, whose normals point
//!   in opposite directions (one is flipped over the other; on a planar surface, an
//!   inverted triangle).
//!
//! Triangles that repeat the three nodes of another triangle of their surface are not
//! refused: [`drop_repeated_triangles`] removes them first (a triangle and its reverse
//! cancel as a surface: a zero-area pocket, which Gmsh writes at the degenerate apex of a
//! very sharp cone; a copy is kept where it fills the hole this leaves).

use rayon::prelude::*;

use super::RecombineError;
use crate::keysort::{bits, bucket_sort, sort_by_prefix};
use crate::mesh::{etype, Mesh, TagCoords};

/// Largest accepted coordinate magnitude of a surface element's node. Quality measures
/// multiply up to four coordinate differences; beyond this they overflow to infinity.
pub(crate) const MAX_COORDINATE: f64 = 1e60;

/// Below this `|(b − a) × (c − a)| / (|ab|² + |bc|² + |ca|²)` a triangle has no area to
/// rounding (an equilateral triangle has √3/6 ≈ 0.29; a needle of height `h` and length
/// `L` about `h / 2L`; slivers of a graded Delaunay mesh reach 5.7·10⁻¹⁴ in
/// `tests/recombine/random.rs` and are kept).
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
    let coords = TagCoords::new(mesh);
    mesh.sorted_surfaces(|b| b.is_linear_face())
        .par_iter()
        .map(|&s| check_surface(mesh, s, &coords))
        .collect::<Result<Vec<()>, _>>()
        .map(|_| ())
}

/// Elements per parallel task.
const CHUNK: usize = 8192;

/// A triangle for the fold check: its nodes, element tag and unit normal.
type FoldTri = ([u64; 3], u64, V);

/// Checks element `i` of block `b` (a 3-node triangle or 4-node quad of `surface`): its
/// triangle with its unit normal, for the fold check (`None`: a quad, or a node unknown).
fn check_element(
    b: &crate::mesh::ElementBlock,
    i: usize,
    surface: i32,
    coords: &TagCoords,
) -> Result<Option<FoldTri>, RecombineError> {
    let k = if b.element_type == etype::TRI3 { 3 } else { 4 };
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
        let Some(c) = coords.get(v) else {
            // unknown node: reported by the topology stage
            return Ok(None);
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
    if k != 3 {
        return Ok(None);
    }
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
    Ok(Some(([nodes[0], nodes[1], nodes[2]], tag, unit)))
}

fn check_surface(mesh: &Mesh, surface: i32, coords: &TagCoords) -> Result<(), RecombineError> {
    // triangles with their normals, for the fold check; elements checked by chunks in
    // parallel, the first refused one in block order reported
    let mut tris: Vec<FoldTri> = Vec::new();
    for b in mesh
        .element_blocks
        .iter()
        .filter(|b| b.entity_tag == surface && b.is_linear_face())
    {
        let chunks: Vec<Result<Vec<FoldTri>, RecombineError>> = (0..b.len())
            .into_par_iter()
            .step_by(CHUNK)
            .map(|from| {
                let mut out = Vec::new();
                for i in from..(from + CHUNK).min(b.len()) {
                    if let Some(t) = check_element(b, i, surface, coords)? {
                        out.push(t);
                    }
                }
                Ok(out)
            })
            .collect();
        for c in chunks {
            tris.extend(c?);
        }
    }
    // triangles repeating another's three nodes were removed before (drop_repeated_triangles)
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

/// +1 when the triangle `t` runs its nodes in the cyclic order of their sorted tags, −1
/// otherwise (its orientation relative to the sorted triple).
fn orientation_sign(t: [u64; 3]) -> i8 {
    let k = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
    if t[(k + 1) % 3] < t[(k + 2) % 3] {
        1
    } else {
        -1
    }
}

/// The triangle on the sorted nodes `s` running the way `sign` says.
fn oriented(s: [u64; 3], sign: i8) -> [u64; 3] {
    if sign > 0 {
        s
    } else {
        [s[0], s[2], s[1]]
    }
}

/// One 3-node triangle of a surface: (surface, sorted nodes, block, index in block, sign).
type TriRef = (i32, [u64; 3], u32, u32, i8);

/// Per (surface, undirected edge), the directed uses of that edge by remaining triangles.
type EdgeUses = std::collections::HashMap<(i32, (u64, u64)), Vec<(u64, u64)>>;

/// Which triangles of `mesh` repeat another triangle's three nodes on the same surface and
/// are to be removed (see [`drop_repeated_triangles`]): per element block, the indices to
/// remove, and one line per surface saying what goes. Empty lines when there are none.
fn repeated_triangles(mesh: &Mesh) -> (Vec<Vec<u32>>, Vec<String>) {
    let mut all: Vec<TriRef> = Vec::new();
    for (bi, b) in mesh.element_blocks.iter().enumerate() {
        // a malformed block (node count not 3 per element) is refused later, by name
        if b.entity_dim != 2 || b.element_type != etype::TRI3 || b.nodes.len() != 3 * b.len() {
            continue;
        }
        for i in 0..b.len() {
            let e = b.element(i);
            let t = [e[0], e[1], e[2]];
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                continue; // refused by check_surface_elements
            }
            let mut s = t;
            s.sort_unstable();
            all.push((b.entity_tag, s, bi as u32, i as u32, orientation_sign(t)));
        }
    }
    // sorted by surface and nodes, then file order (block, index)
    all.par_sort_unstable();
    let mut remove: Vec<Vec<u32>> = vec![Vec::new(); mesh.element_blocks.len()];
    // runs of equal (surface, nodes): [start, end)
    let mut runs: Vec<(usize, usize)> = Vec::new();
    let mut i = 0;
    while i < all.len() {
        let mut j = i + 1;
        while j < all.len() && all[j].0 == all[i].0 && all[j].1 == all[i].1 {
            j += 1;
        }
        if j - i > 1 {
            runs.push((i, j));
        }
        i = j;
    }
    if runs.is_empty() {
        return (remove, Vec::new());
    }
    let mut removed = vec![false; all.len()];
    // first every set that cancels (as many copies each way) goes whole, and the others
    // keep one copy running the way of the majority
    let mut cancelled: Vec<(usize, usize)> = Vec::new();
    for &(i, j) in &runs {
        let net: i32 = all[i..j].iter().map(|x| i32::from(x.4)).sum();
        let keep = (net != 0).then(|| (i..j).find(|&k| i32::from(all[k].4) == net.signum()));
        for (k, r) in removed.iter_mut().enumerate().take(j).skip(i) {
            *r = keep.flatten() != Some(k);
        }
        if net == 0 {
            cancelled.push((i, j));
        }
    }
    // then a cancelled set gets one copy back when that copy fills a hole the removal left:
    // each of its edges then has at most two triangles, run in opposite directions, and one
    // edge at least is shared with a remaining triangle (a triangle written once more,
    // reversed, beside a sound mesh); pockets whose edges have no other triangle, or that
    // would make an edge of three, stay out. Sets are taken in file order.
    cancelled.sort_by_key(|&(i, _)| (all[i].2, all[i].3));
    let key = |a: u64, b: u64| (a.min(b), a.max(b));
    // directed uses of the cancelled sets' edges by the remaining triangles
    let mut uses: EdgeUses = EdgeUses::new();
    for &(i, _) in &cancelled {
        let (s, n) = (all[i].0, all[i].1);
        for k in 0..3 {
            uses.entry((s, key(n[k], n[(k + 1) % 3]))).or_default();
        }
    }
    for (x, gone) in all.iter().zip(&removed) {
        if *gone {
            continue;
        }
        let t = oriented(x.1, x.4);
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if let Some(u) = uses.get_mut(&(x.0, key(a, b))) {
                u.push((a, b));
            }
        }
    }
    for &(i, j) in &cancelled {
        let (s, n) = (all[i].0, all[i].1);
        let fits = |sign: i8, uses: &EdgeUses| {
            let t = oriented(n, sign);
            let mut shared = 0;
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                match uses.get(&(s, key(a, b))).map(Vec::as_slice) {
                    None | Some([]) => {}
                    Some([(p, q)]) if (*p, *q) == (b, a) => shared += 1,
                    _ => return false,
                }
            }
            shared > 0
        };
        let first = all[i].4;
        if let Some(sign) = [first, -first].into_iter().find(|&g| fits(g, &uses)) {
            if let Some(k) = (i..j).find(|&k| all[k].4 == sign) {
                removed[k] = false;
                let t = oriented(n, sign);
                for m in 0..3 {
                    let (a, b) = (t[m], t[(m + 1) % 3]);
                    if let Some(u) = uses.get_mut(&(s, key(a, b))) {
                        u.push((a, b));
                    }
                }
            }
        }
    }
    // per surface: (triangles removed, sets, example)
    let mut per_surface: Vec<(i32, usize, usize, String)> = Vec::new();
    for &(i, j) in &runs {
        let s = all[i].0;
        if per_surface.last().is_none_or(|p| p.0 != s) {
            per_surface.push((s, 0, 0, String::new()));
        }
        let gone: Vec<u64> = (i..j)
            .filter(|&k| removed[k])
            .map(|k| mesh.element_blocks[all[k].2 as usize].tags[all[k].3 as usize])
            .collect();
        for k in (i..j).filter(|&k| removed[k]) {
            remove[all[k].2 as usize].push(all[k].3);
        }
        if let Some(p) = per_surface.last_mut() {
            p.1 += gone.len();
            p.2 += 1;
            if p.3.is_empty() {
                let n = all[i].1;
                let kept = (i..j)
                    .find(|&k| !removed[k])
                    .map(|k| mesh.element_blocks[all[k].2 as usize].tags[all[k].3 as usize]);
                p.3 = format!(
                    "on nodes {}, {}, {}: element(s) {} removed{}",
                    n[0],
                    n[1],
                    n[2],
                    gone.iter()
                        .map(|t| t.to_string())
                        .collect::<Vec<_>>()
                        .join(", "),
                    kept.map(|t| format!(", element {t} kept"))
                        .unwrap_or_default()
                );
            }
        }
    }
    let lines = per_surface
        .into_iter()
        .map(|(s, n, sets, example)| {
            format!(
                "surface {s}: {sets} set(s) of triangles on the same three nodes; removed {n} triangle(s) (a triangle and its reverse cancel as a surface, a zero-area pocket such as Gmsh writes at a degenerate apex or seam; a copy is kept where it runs like its neighbours), e.g. {example}"
            )
        })
        .collect();
    (remove, lines)
}

/// A copy of `mesh` without the 3-node triangles that repeat the three nodes of another
/// triangle of the same surface, with one line per such surface saying what was removed
/// (for the log); `None` when there are none. Taken as an oriented surface, a triangle and
/// its reverse cancel: together they are a pocket of zero area (Gmsh writes such pairs at
/// the degenerate apex or seam of a very sharp cone), and a triangle repeated in the same
/// orientation is the same face twice. So for every set of triangles on the same three
/// nodes: when as many run one way as the other, all are removed, except that one copy is
/// put back where it fills the hole this leaves (each of its edges then has at most two
/// triangles, run in opposite directions, and one at least is shared with a remaining
/// triangle: a triangle written once more, reversed, beside a sound mesh); otherwise one
/// copy running the way of the majority (the first in file order) is kept. What stays has
/// the same area-weighted normal at every node. Triangles naming a node twice are left to
/// [`check_surface_elements`]; element blocks emptied are removed.
pub(crate) fn drop_repeated_triangles(mesh: &Mesh) -> Option<(Mesh, Vec<String>)> {
    let (remove, lines) = repeated_triangles(mesh);
    if lines.is_empty() {
        return None;
    }
    let mut out = mesh.clone();
    for (b, rm) in out.element_blocks.iter_mut().zip(&remove) {
        if rm.is_empty() {
            continue;
        }
        let mut gone = vec![false; b.len()];
        for &r in rm {
            gone[r as usize] = true;
        }
        let k = b.nodes_per_element();
        let mut w = 0;
        for (r, &g) in gone.iter().enumerate() {
            if g {
                continue;
            }
            b.tags[w] = b.tags[r];
            b.nodes.copy_within(r * k..(r + 1) * k, w * k);
            if let Some(p) = b.partitions.as_mut() {
                p.swap(w, r);
            }
            w += 1;
        }
        b.tags.truncate(w);
        b.nodes.truncate(w * k);
        if let Some(p) = b.partitions.as_mut() {
            p.truncate(w);
        }
    }
    let mut bi = 0;
    out.element_blocks.retain(|b| {
        let keep = remove[bi].is_empty() || !b.is_empty();
        bi += 1;
        keep
    });
    out.invalidate_element_data();
    Some((out, lines))
}
