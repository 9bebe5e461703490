//! Element-level input checks run before any recombination work: surface elements that no
//! recombination can turn into valid quads are refused with the surface, the element tag
//! and the reason, instead of producing a broken mesh (classes found by fuzzing the
//! pipeline, see `fuzz/`):
//!
//! - a triangle or quad that names the same node twice;
//! - a node of a surface element with a non-finite coordinate, or one so large that
//!   products of coordinate differences overflow ([`MAX_COORDINATE`]);
//! - a triangle of zero area (its nodes coincide or are collinear, to rounding);
//! - an edge shared by three or more triangles of one surface, two triangles running their
//!   common edge in the same direction, a fold (see
//!   [`SurfaceTopo::new`](super::topology::SurfaceTopo::new)).
//!
//! Quads are checked by [`check_surface_elements`] before any other work. The triangles of
//! a recombined surface are checked where its topology is built, before parity repair:
//! [`triangle_normals`] checks each one and gives the normals, then the topology refuses
//! edges while pairing every edge's triangles, without a sort of its own. Periodic slave
//! surfaces get no topology (their master's quads are mapped onto them): their triangles
//! and edges are checked by [`check_surface_elements`].
//!
//! Triangles that repeat the three nodes of another triangle of their surface are not
//! refused: [`drop_repeated_triangles`] removes them first (a triangle and its reverse
//! cancel as a surface: a zero-area pocket, which Gmsh writes at the degenerate apex of a
//! very sharp cone; a copy is kept where it fills the hole this leaves).

use rayon::prelude::*;

use super::topology::{edge_refusal, EdgeProblem, FOLDED};
use super::RecombineError;
use crate::keysort::{bits, bucket_sort, sort_by_prefix};
use crate::mesh::{etype, Mesh, NodeTable, TagCoords};

/// Largest accepted coordinate magnitude of a surface element's node. Quality measures
/// multiply up to four coordinate differences; beyond this they overflow to infinity.
pub(crate) const MAX_COORDINATE: f64 = 1e60;

/// Below this `|(b − a) × (c − a)| / (|ab|² + |bc|² + |ca|²)` a triangle has no area to
/// rounding (an equilateral triangle has √3/6 ≈ 0.29; a needle of height `h` and length
/// `L` about `h / 2L`; slivers of a graded Delaunay mesh reach 5.7·10⁻¹⁴ in
/// `tests/recombine/random.rs` and are kept).
const ZERO_AREA: f64 = 1e-15;

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

/// Checks every 4-node quad of every surface, and the triangles and edges of periodic
/// slave surfaces (see the module doc; the triangles of the other surfaces are checked
/// with their topology, [`triangle_normals`]).
/// Unknown nodes are left to the later stages, which name them.
pub(crate) fn check_surface_elements(mesh: &Mesh) -> Result<(), RecombineError> {
    let slaves = super::periodic::slave_surfaces(mesh);
    // only quads and the faces of periodic slaves are checked here
    if !mesh.element_blocks.iter().any(|b| {
        b.is_linear_face() && (b.element_type != etype::TRI3 || slaves.contains(&b.entity_tag))
    }) {
        return Ok(());
    }
    let coords = TagCoords::new(mesh);
    mesh.sorted_surfaces(|b| b.is_linear_face())
        .par_iter()
        .map(|&s| check_surface(mesh, s, &coords, slaves.contains(&s)))
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
    let unit = check_face(surface, b.tags[i], nodes, |v| v, |j| coords.get(nodes[j]))?;
    Ok(unit.map(|u| ([nodes[0], nodes[1], nodes[2]], b.tags[i], u)))
}

/// Checks one 3-node triangle or 4-node quad (element `tag` of `surface`, node tags
/// `nodes`, `coord(j)` the coordinates of its node `j`, `None` when unknown): its unit
/// normal when it is a triangle whose nodes are known.
fn check_face<N: Copy + PartialEq>(
    surface: i32,
    tag: u64,
    nodes: &[N],
    node_tag: impl Fn(N) -> u64,
    coord: impl Fn(usize) -> Option<[f64; 3]>,
) -> Result<Option<V>, RecombineError> {
    let k = nodes.len();

    for (j, &v) in nodes.iter().enumerate() {
        if nodes[..j].contains(&v) {
            return Err(invalid(
                surface,
                tag,
                format!(
                    "it names node {} twice; a {} needs {k} distinct nodes",
                    node_tag(v),
                    if k == 3 { "triangle" } else { "quad" }
                ),
            ));
        }
    }
    let mut p = [[0.0; 3]; 4];
    for (j, &v) in nodes.iter().enumerate() {
        let Some(c) = coord(j) else {
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
                        "its node {} has a coordinate {x:e}, beyond the supported magnitude {MAX_COORDINATE:e}",
                        node_tag(v)
                    )
                } else {
                    format!(
                        "its node {} has a coordinate that is not a finite number",
                        node_tag(v)
                    )
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
                node_tag(nodes[0]),
                node_tag(nodes[1]),
                node_tag(nodes[2]),
                area2 / scale
            ),
        ));
    }
    Ok(Some(n.map(|x| x / area2)))
}

/// Checks the triangles of a recombined surface (`tris` as [`NodeTable`] ids, element tags
/// `elem_tags`) as [`check_surface_elements`] does the others, the first refused one in
/// order reported: their unit normals, for the topology's fold check.
pub(crate) fn triangle_normals(
    surface: i32,
    tris: &[[u32; 3]],
    elem_tags: &[u64],
    nodes: &NodeTable,
) -> Result<Vec<glam::DVec3>, RecombineError> {
    let mut normals = vec![glam::DVec3::ZERO; tris.len()];
    let first_refused = normals
        .par_chunks_mut(CHUNK)
        .enumerate()
        .find_map_first(|(c, out)| {
            for (i, n) in out.iter_mut().enumerate() {
                let t = c * CHUNK + i;
                let node_tag = |v: u32| nodes.tags[v as usize];
                let coord = |j: usize| Some(nodes.coords[tris[t][j] as usize].to_array());
                match check_face(surface, elem_tags[t], &tris[t], node_tag, coord) {
                    Ok(u) => *n = glam::DVec3::from(u.unwrap_or_default()),
                    Err(e) => return Some(e),
                }
            }
            None
        });
    match first_refused {
        Some(e) => Err(e),
        None => Ok(normals),
    }
}

/// Checks the quads of `surface`, and with `edges` (a periodic slave) its triangles and
/// edges too (see the module doc).
fn check_surface(
    mesh: &Mesh,
    surface: i32,
    coords: &TagCoords,
    edges: bool,
) -> Result<(), RecombineError> {
    // triangles with their normals, for the edge checks; elements checked by chunks in
    // parallel, the first refused one in block order reported
    let mut tris: Vec<FoldTri> = Vec::new();
    // the triangles of recombined surfaces are checked with their topology
    // (triangle_normals), those of periodic slaves here
    for b in mesh.element_blocks.iter().filter(|b| {
        b.entity_tag == surface && b.is_linear_face() && (edges || b.element_type != etype::TRI3)
    }) {
        let chunks: Vec<Result<Vec<FoldTri>, RecombineError>> = (0..b.len())
            .into_par_iter()
            .step_by(CHUNK)
            .map(|from| {
                let mut out = Vec::new();
                for i in from..(from + CHUNK).min(b.len()) {
                    if let Some(t) = check_element(b, i, surface, coords)? {
                        if edges {
                            out.push(t);
                        }
                    }
                }
                Ok(out)
            })
            .collect();
        for c in chunks {
            tris.extend(c?);
        }
    }
    if !edges {
        return Ok(());
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
    // runs of one edge, in (edge, first node, triangle) order: the first refused one
    for run in half.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
        let problem = match run {
            [_, _, _, ..] => EdgeProblem::non_manifold(
                run.iter().map(|x| x.3 as usize).collect(),
                |t, u| dot(tris[t].2, tris[u].2),
            ),
            [a, b] if a.2 == b.2 => EdgeProblem::SameDirection {
                first: a.3 as usize,
                second: b.3 as usize,
                from: a.2,
                to: if a.2 == a.0 { a.1 } else { a.0 },
            },
            [a, b] if dot(tris[a.3 as usize].2, tris[b.3 as usize].2) < FOLDED => {
                EdgeProblem::Folded {
                    first: a.3 as usize,
                    second: b.3 as usize,
                }
            }
            _ => continue,
        };
        return Err(edge_refusal(surface, (run[0].0, run[0].1), problem, |t| {
            tris[t].1
        }));
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

/// False when no two 3-node surface triangles of `mesh` have the same three nodes (the
/// common case, found with one linear sort of the sorted node triples; true may also mean
/// two triangles of different surfaces on the same nodes, which [`repeated_triangles`]
/// sorts out).
fn may_repeat(mesh: &Mesh) -> bool {
    let mut keys: Vec<[u64; 3]> = Vec::new();
    for b in mesh.element_blocks.iter().filter(|b| {
        b.entity_dim == 2 && b.element_type == etype::TRI3 && b.nodes.len() == 3 * b.len()
    }) {
        keys.extend(b.nodes.chunks_exact(3).map(|e| {
            let mut t = [e[0], e[1], e[2]];
            t.sort_unstable();
            t
        }));
    }
    if !bucket_sort(&mut keys, |k| k[0]) {
        keys.par_sort_unstable();
    }
    keys.windows(2).any(|w| w[0] == w[1])
}

/// Which triangles of `mesh` repeat another triangle's three nodes on the same surface and
/// are to be removed (see [`drop_repeated_triangles`]): per element block, the indices to
/// remove, and one line per surface saying what goes. Empty lines when there are none.
fn repeated_triangles(mesh: &Mesh) -> (Vec<Vec<u32>>, Vec<String>) {
    if !may_repeat(mesh) {
        return (vec![Vec::new(); mesh.element_blocks.len()], Vec::new());
    }
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
