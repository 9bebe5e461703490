//! Strip end turns: the ends of narrow faces whose end curve has a node in its middle, such
//! as the quarter faces of a thin wire meshed with three nodes on each arc.
//!
//! Such a face is a strip (see `recombine::strip`) one row of two triangles wide, and its
//! first row is a *pentagon*: the end curve's two segments `A0 M`, `M B0`, the side
//! segments `A0 A1`, `B0 B1` and the rung `A1 B1` to the next row, cut into three triangles.
//! Two quads cross the end curve and one crosses each row, so no quad mesh of the strip
//! alone pairs one quad per row: the matching pairs each row across its long diagonal (a
//! parallelogram as thin as the face is narrow) and the strip's own plan needs a midline
//! from end to end, one quad per triangle. Turning the second quad across a side curve
//! costs three quads per end instead: a node `P` on the side segment `A0 A1` near `A1`, a
//! node `X` inside at `P`'s height between `M` and the other side, and the quads
//! `P A0 M X`, `M B0 B1 X` and `B1 A1 P X`. The quad that turns crosses the side curve at
//! `P` into the face on the other side, whose end turns the same way there, so two faces
//! that share a side segment at the same end node turn together: [`turns`] pairs them, and
//! [`apply_turns`] puts `P` on the curve (its line element split in two), `X` in each
//! face, and each pentagon's three triangles as the six of its three quads, which the
//! matching then pairs back.
//!
//! **Invariant:** a face turns at both its ends or at none, so each keeps the parity of its
//! triangle count (a turn adds three triangles to each of its two faces); a turn is made only
//! where both faces' rows and turn quads have an η (eq. 3) of at least
//! `strip::REMESH_BELOW`, better by `strip::MIN_GAIN` than the face's best plan without a
//! midline; `P` lies on the chord of `A0 A1`, so planar areas are unchanged, and it is
//! recorded as a parity split of that segment.

use super::*;
use super::plan::{blocked_edges, line_curves, segment_curve};
use crate::recombine::strip::{no_midline_worst, strips, Strip, MIN_GAIN, REMESH_BELOW};

/// One end of a strip: its surface (index into the surface works), its pentagon's three
/// triangles and the pentagon's nodes `[A1, A0, M, B0, B1]` in the triangles' orientation
/// (the rung runs from `B1` to `A1`), and the least η its turn must reach.
#[derive(Debug, Clone, Copy)]
struct End {
    work: usize,
    tris: [usize; 3],
    cycle: [u32; 5],
    floor: f64,
}

/// A turn of two strip ends across the side segment they share (see the module
/// documentation).
#[derive(Debug, Clone)]
pub(crate) struct Turn {
    /// The end node of the side segment, `A0`, and its other node `A1` (global ids).
    a0: u32,
    a1: u32,
    /// The segment's curve, when known (else `P` goes on the first face, as a parity
    /// split's node does).
    curve: Option<i32>,
    /// `P`'s fraction of the way from `A1` to `A0`.
    at: f64,
    /// The two ends, each turned as [`TurnEnd`] says.
    ends: [TurnEnd; 2],
}

/// One end of a [`Turn`]: the strip end, the side of its pentagon that holds the segment
/// (0: the `A` side, 1: the `B` side), and its three quads and `X`'s position as
/// [`template`] gave them when the turn was weighed.
#[derive(Debug, Clone, Copy)]
struct TurnEnd {
    end: End,
    side: usize,
    quads: [[u32; 4]; 3],
    x: DVec3,
}

/// How far from `A1` a turn puts `P`, as a share of the strip's width at its first rung
/// (measured against 0.3 and 0.8 in BENCHMARKS.md, "Measurements behind the defaults").
const TURN_DEPTH: f64 = 0.5;

/// `P`'s place along the side segment at most (a share of the segment from `A1`): beyond,
/// the row is too short for a turn.
const MAX_AT: f64 = 0.45;

/// A corner of a turn's quads: a node id, or `P` or `X`.
const P: u32 = u32::MAX;
const X: u32 = u32::MAX - 1;

/// The turns of the strips of `work` (see the module documentation): the pairs of ends whose
/// turns give the better worst quad first, and only for strips that turn at both ends.
pub(crate) fn turns(mesh: &Mesh, nodes: &NodeTable, work: &[SurfaceWork]) -> Vec<Turn> {
    // each strip's two ends
    let mut ends: Vec<End> = Vec::new();
    for (wi, w) in work.iter().enumerate() {
        for s in strips(w) {
            for (tris, cycle, floor) in strip_ends(w, nodes, &s).into_iter().flatten() {
                ends.push(End {
                    work: wi,
                    tris,
                    cycle,
                    floor,
                });
            }
        }
    }
    if ends.is_empty() {
        return Vec::new();
    }
    let line_curve = line_curves(mesh, nodes);
    let blocked = blocked_edges(mesh, nodes);
    // how many triangles of all surfaces hold each wall segment
    let mut holders: HashMap<u64, usize> = HashMap::new();
    for w in work {
        for (t, tri) in w.topo.tris.iter().enumerate() {
            for k in 0..3 {
                if w.topo.nbr[3 * t + k] == NONE {
                    *holders.entry(edge_key(tri[k], tri[(k + 1) % 3])).or_default() += 1;
                }
            }
        }
    }
    // the ends that may turn across each side segment: a wall segment between two surfaces
    // that the two triangles of two pentagons hold and no quad
    let mut options: HashMap<u64, Vec<(usize, usize)>> = HashMap::new();
    for (i, e) in ends.iter().enumerate() {
        for side in 0..2 {
            let m = mirrored(e.cycle, side);
            let key = edge_key(m[0], m[1]);
            if holders.get(&key) == Some(&2) && blocked.binary_search(&key).is_err() {
                options.entry(key).or_default().push((i, side));
            }
        }
    }
    // the pairs of ends at the same end node of a shared segment, better worst quad first
    let mut keys: Vec<u64> = options.keys().copied().collect();
    keys.sort_unstable();
    let mut pairs: Vec<(f64, Turn, [usize; 2])> = Vec::new();
    for key in keys {
        let o = &options[&key];
        for i in 0..o.len() {
            for &(b, sb) in &o[i + 1..] {
                let (a, sa) = o[i];
                let (ma, mb) = (mirrored(ends[a].cycle, sa), mirrored(ends[b].cycle, sb));
                if ma[1] != mb[1] {
                    continue;
                }
                let (a0, a1) = (ma[1], ma[0]);
                let len = (nodes.coords[a0 as usize] - nodes.coords[a1 as usize]).length();
                let width = |m: [u32; 5]| (nodes.coords[m[0] as usize] - nodes.coords[m[4] as usize]).length();
                let at = (TURN_DEPTH * width(ma).min(width(mb)) / len).min(MAX_AT);
                let end = |i: usize, side: usize, m: [u32; 5]| {
                    let (eta, quads, x) = template(nodes, m, at, ends[i].floor)?;
                    let end = ends[i];
                    Some((eta, TurnEnd { end, side, quads, x }))
                };
                let (Some((x, ea)), Some((y, eb))) = (end(a, sa, ma), end(b, sb, mb)) else {
                    continue;
                };
                let curve = segment_curve(mesh, nodes, &line_curve, key);
                let turn = Turn {
                    a0,
                    a1,
                    curve,
                    at,
                    ends: [ea, eb],
                };
                pairs.push((x.min(y), turn, [a, b]));
            }
        }
    }
    pairs.sort_by(|x, y| y.0.total_cmp(&x.0));
    let mut taken: Vec<Option<usize>> = vec![None; ends.len()];
    for (i, p) in pairs.iter().enumerate() {
        let [a, b] = p.2;
        if taken[a].is_none() && taken[b].is_none() {
            taken[a] = Some(i);
            taken[b] = Some(i);
        }
    }
    // a strip turns at both ends or at none (ends are pushed two by two, per strip)
    loop {
        let mut dropped = false;
        for s in 0..ends.len() / 2 {
            if let [Some(i), None] | [None, Some(i)] = [taken[2 * s], taken[2 * s + 1]] {
                for e in pairs[i].2 {
                    taken[e] = None;
                }
                dropped = true;
            }
        }
        if !dropped {
            break;
        }
    }
    let mut chosen: Vec<usize> = taken.into_iter().flatten().collect();
    chosen.sort_unstable();
    chosen.dedup();
    chosen.into_iter().map(|i| pairs[i].1.clone()).collect()
}

/// The two ends of strip `s` of `w` as (pentagon triangles, pentagon nodes, least η of a
/// turn), when the strip may turn at both: an open strip whose first and last rows are
/// pentagons and whose rows between them are cells of two triangles that pair into quads
/// of at least that η, which is [`REMESH_BELOW`] or [`MIN_GAIN`] above the strip's best
/// plan without a midline.
#[allow(clippy::type_complexity)]
fn strip_ends(
    w: &SurfaceWork,
    nodes: &NodeTable,
    s: &Strip,
) -> Option<[([usize; 3], [u32; 5], f64); 2]> {
    if s.closed {
        return None;
    }
    let count: usize = s.units.iter().map(Vec::len).sum();
    if count % 2 == 1 || count < 8 {
        return None;
    }
    let rev: Vec<Vec<usize>> = s.units.iter().rev().cloned().collect();
    let (first, i) = pentagon(w, &s.units)?;
    let (last, j) = pentagon(w, &rev)?;
    let middle = &s.units[i..s.units.len() - j];
    if middle.iter().any(|u| u.len() != 1) {
        return None;
    }
    let at = |v: u32| (v, nodes.coords[v as usize]);
    let rows = middle
        .chunks(2)
        .map(|c| match c {
            [a, b] => pair_eta(&w.topo.tris[a[0]].map(at), &w.topo.tris[b[0]].map(at)),
            _ => f64::NEG_INFINITY,
        })
        .fold(f64::INFINITY, f64::min);
    let now = no_midline_worst(&w.topo, s, &nodes.coords).unwrap_or(f64::NEG_INFINITY);
    let floor = REMESH_BELOW.max(now + MIN_GAIN);
    (rows >= floor).then_some([(first.0, first.1, floor), (last.0, last.1, floor)])
}

/// The pentagon at the start of `units` (see the module documentation) as its three
/// triangles and its nodes `[A1, A0, M, B0, B1]`, with the number of units it takes; `None`
/// when the first three triangles are no pentagon with four wall segments and one rung.
#[allow(clippy::type_complexity)]
fn pentagon(w: &SurfaceWork, units: &[Vec<usize>]) -> Option<(([usize; 3], [u32; 5]), usize)> {
    let mut tris: Vec<usize> = Vec::new();
    let mut taken = 0;
    while tris.len() < 3 {
        tris.extend(units.get(taken)?);
        taken += 1;
    }
    if tris.len() != 3 {
        return None;
    }
    // the union's boundary: the directed edges whose reverse is not in it
    let edges: Vec<(u32, u32, bool)> = tris
        .iter()
        .flat_map(|&t| {
            let tri = w.topo.tris[t];
            (0..3).map(move |k| (tri[k], tri[(k + 1) % 3], w.topo.nbr[3 * t + k] == NONE))
        })
        .collect();
    let boundary: Vec<(u32, u32, bool)> = edges
        .iter()
        .copied()
        .filter(|e| !edges.iter().any(|f| (f.0, f.1) == (e.1, e.0)))
        .collect();
    if boundary.len() != 5 || boundary.iter().filter(|e| !e.2).count() != 1 {
        return None;
    }
    let rung = boundary.iter().find(|e| !e.2)?;
    let mut cycle = [rung.1; 5];
    for k in 1..5 {
        let from = cycle[k - 1];
        cycle[k] = boundary.iter().find(|e| e.0 == from)?.1;
    }
    let distinct = (0..5).all(|i| (i + 1..5).all(|j| cycle[i] != cycle[j]));
    (distinct && boundary.iter().any(|e| (e.0, e.1) == (cycle[4], cycle[0])))
        .then_some(((tris.try_into().ok()?, cycle), taken))
}

/// The pentagon nodes `cycle` named for a turn on `side` (0: the `A` side, the nodes as
/// they are; 1: the `B` side, `[B1, B0, M, A0, A1]`, against the triangles' orientation).
fn mirrored(cycle: [u32; 5], side: usize) -> [u32; 5] {
    match side {
        0 => cycle,
        _ => [cycle[4], cycle[3], cycle[2], cycle[1], cycle[0]],
    }
}

/// A turn's three quads on the pentagon `m` (named by [`mirrored`]) with `P` at `at` of the
/// way from `A1` to `A0`: their worst η (eq. 3, about the pentagon's normal), the quads in
/// `m`'s order (corners: node ids, [`P`], [`X`]) and `X`'s position; `None` when the worst
/// is under `floor`.
fn template(
    nodes: &NodeTable,
    m: [u32; 5],
    at: f64,
    floor: f64,
) -> Option<(f64, [[u32; 4]; 3], DVec3)> {
    let pos = |v: u32| nodes.coords[v as usize];
    let [a1, a0, mid, b0, b1] = m;
    let p = pos(a1) + (pos(a0) - pos(a1)) * at;
    // the point of the other side at P's distance from the rung
    let depth = (pos(a0) - pos(a1)).length() * at;
    let side = pos(b0) - pos(b1);
    let q = pos(b1) + side * (depth / side.length()).min(MAX_AT);
    let x = pos(mid) + 0.5 * ((p - pos(a0)) + (q - pos(b0)));
    let quads = [[P, a0, mid, X], [mid, b0, b1, X], [b1, a1, P, X]];
    let corner = |v: u32| match v {
        P => p,
        X => x,
        _ => pos(v),
    };
    let normal = (pos(a0) - pos(a1)).cross(pos(b1) - pos(a1))
        + (pos(b0) - pos(mid)).cross(pos(a0) - pos(mid));
    let worst = quads
        .iter()
        .map(|q| crate::quality::eta_signed(&q.map(corner), normal))
        .fold(f64::INFINITY, f64::min);
    (worst >= floor).then_some((worst, quads, x))
}

/// Applies `turns` to `mesh` (whose node ids are those of `nodes`): for each, `P` on its
/// curve (the curve's node block, parametric coordinates interpolated; the line element
/// holding the segment split in two, the second piece with a fresh tag; without curve data,
/// in the first face's node block), `X` in each of its
/// two surfaces, and each pentagon's three triangles replaced by the six of its quads (the
/// first three keep the pentagon's element tags, the others get fresh ones), orientation
/// kept. Returns `P` of each turn as a parity split.
pub(crate) fn apply_turns(
    mesh: &mut Mesh,
    nodes: &NodeTable,
    work: &[SurfaceWork],
    turns: &[Turn],
) -> Vec<ParitySplit> {
    let mut next_node = mesh.max_node_tag() + 1;
    let mut next_elem = mesh.max_element_tag() + 1;
    let tag = |v: u32| nodes.tags[v as usize];
    let mut out = Vec::new();
    for t in turns {
        let (a0, a1) = (nodes.coords[t.a0 as usize], nodes.coords[t.a1 as usize]);
        let p_tag = next_node;
        next_node += 1;
        let (dim, ent) = match t.curve {
            Some(c) => (1, c),
            None => (2, work[t.ends[0].end.work].tag),
        };
        add_node(
            mesh,
            nodes,
            dim,
            ent,
            p_tag,
            a1 + (a0 - a1) * t.at,
            &[t.a1, t.a0],
            Some(&[1.0 - t.at, t.at]),
        );
        split_line(mesh, (tag(t.a0), tag(t.a1)), p_tag, &mut next_elem);
        let mut surfaces = Vec::new();
        for &TurnEnd {
            end: e,
            side,
            quads,
            x,
        } in &t.ends
        {
            let w = &work[e.work];
            surfaces.push(w.tag);
            let x_tag = next_node;
            next_node += 1;
            add_node(mesh, nodes, 2, w.tag, x_tag, x, &[], None);
            let corner = |v: u32| match v {
                P => p_tag,
                X => x_tag,
                _ => tag(v),
            };
            // on the B side the quads run against the pentagon's orientation
            let tris: Vec<[u64; 3]> = quads
                .iter()
                .flat_map(|q| {
                    let mut q = q.map(corner);
                    if side == 1 {
                        q.reverse();
                    }
                    [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
                })
                .collect();
            let old: Vec<u64> = e.tris.iter().map(|&i| w.elem_tags[i]).collect();
            replace_triangles(mesh, w.tag, &old, &tris, &mut next_elem);
        }
        surfaces.sort_unstable();
        surfaces.dedup();
        out.push(ParitySplit {
            curve: t.curve,
            surfaces,
            segment: (tag(t.a0), tag(t.a1)),
            new_node: p_tag,
            turn: true,
        });
    }
    out
}

/// Splits the 2-node line element(s) holding the segment `seg` (node tags) at node `m`; the
/// second piece gets tag `next_elem` (then incremented).
fn split_line(mesh: &mut Mesh, seg: (u64, u64), m: u64, next_elem: &mut u64) {
    for blk in mesh
        .element_blocks
        .iter_mut()
        .filter(|b| b.element_type == etype::LINE2)
    {
        for i in 0..blk.len() {
            let e = [blk.nodes[2 * i], blk.nodes[2 * i + 1]];
            if (e[0], e[1]) != seg && (e[1], e[0]) != seg {
                continue;
            }
            blk.nodes[2 * i + 1] = m;
            blk.nodes.extend_from_slice(&[m, e[1]]);
            blk.tags.push(*next_elem);
            *next_elem += 1;
            if let Some(parts) = blk.partitions.as_mut() {
                let v = parts.get(i).cloned().unwrap_or_default();
                parts.push(v);
            }
        }
    }
}

/// Replaces the triangles of surface `s` tagged `old` by `new` (node tags): the first ones
/// take the old triangles' places and tags, the rest are appended to the block of the first
/// old triangle with fresh tags from `next_elem`.
fn replace_triangles(mesh: &mut Mesh, s: i32, old: &[u64], new: &[[u64; 3]], next_elem: &mut u64) {
    let mut slots: Vec<(usize, usize)> = Vec::new();
    for (bi, blk) in mesh.element_blocks.iter().enumerate() {
        if blk.element_type != etype::TRI3 || blk.entity_dim != 2 || blk.entity_tag != s {
            continue;
        }
        for (i, t) in blk.tags.iter().enumerate() {
            if old.contains(t) {
                slots.push((bi, i));
            }
        }
    }
    let Some(&(first, _)) = slots.first() else {
        return;
    };
    let mut rest = new.iter();
    for (&(bi, i), t) in slots.iter().zip(&mut rest) {
        mesh.element_blocks[bi].nodes[3 * i..3 * i + 3].copy_from_slice(t);
    }
    let blk = &mut mesh.element_blocks[first];
    let part = blk.partitions.as_ref().and_then(|p| p.get(slots[0].1).cloned());
    for t in rest {
        blk.nodes.extend_from_slice(t);
        blk.tags.push(*next_elem);
        *next_elem += 1;
        if let (Some(parts), Some(v)) = (blk.partitions.as_mut(), part.as_ref()) {
            parts.push(v.clone());
        }
    }
}
