//! Strips: regions whose every triangle lies between the region's walls in one row, such as
//! the narrow face of a chamfer or a small fillet, or a thin band round a hole. Their
//! triangles form one path (open at both ends) or one cycle (a closed band), so the
//! matching has one or two ways to pair them, and every node is on a wall: no later stage
//! can move a node to mend a poor quad. Where the path's pairs make a poor quad (a strip
//! whose end is a fan of three triangles pairs the fan's two outer triangles into a quad
//! with a straight corner, and every pair after it across the long diagonals of the row),
//! [`plans`] meshes the strip again: cells of one to four consecutive units (see
//! [`Strip`]), each one quad or two, and between two cells of odd triangle counts a midline
//! of new nodes on the interior edges, so that each cell on it is cut into two quads; the
//! recombination takes the plans within the element count and [`apply`] puts them in.
//!
//! **Invariant:** a remeshed strip keeps its walls (no node on a wall edge, no wall edge
//! split), so the surfaces round it and the curves are unchanged; each quad is a part of
//! one cell, oriented like its triangles, and takes the element tag of a triangle of that
//! cell that no other quad takes.

use glam::DVec3;

use super::post::{merge, Faces, NewNode};
use super::surface::SurfaceWork;
use super::topology::{SurfaceTopo, NONE};

/// A strip's units in the order of their path (from one end) or cycle. A unit is a
/// triangle with the triangles that have no other neighbour than it (the two outer
/// triangles of a fan of three at a strip's end, say); consecutive units share one edge.
#[derive(Debug, Clone)]
pub(crate) struct Strip {
    /// Each unit's triangles (indices into the surface's topology), the first one the
    /// unit's own.
    pub units: Vec<Vec<usize>>,
    /// The units close into a band (a cycle).
    pub closed: bool,
}

/// The triangles of region `local` of `w` in the order of the region's dual path (from one
/// end) or cycle (a closed band), and whether it closes. `None` when the region is not a
/// strip whose triangles form one path or one cycle (a triangle with three neighbours).
pub(super) fn strip_order(w: &SurfaceWork, local: u32) -> Option<(Vec<usize>, bool)> {
    let members: Vec<usize> = (0..w.topo.len())
        .filter(|&t| w.region[t] == local)
        .collect();
    order(&w.topo, &members)
}

/// [`strip_order`] of the triangles `members` (one region, in index order).
fn order(topo: &SurfaceTopo, members: &[usize]) -> Option<(Vec<usize>, bool)> {
    let nbrs = |t: usize| -> Vec<usize> {
        topo.nbr[3 * t..3 * t + 3]
            .iter()
            .filter(|&&u| u != NONE)
            .map(|&u| u as usize)
            .collect()
    };
    if members.iter().any(|&t| nbrs(t).len() == 3) {
        return None;
    }
    let end = members.iter().copied().find(|&t| nbrs(t).len() < 2);
    walk(members.len(), end, members.first().copied()?, nbrs)
}

/// The path or cycle through `count` items from `start` (an end of the path, `end`, when
/// there is one), each step to a neighbour (`nbrs`, at most two) other than the one it came
/// from, and whether it closes; `None` when it does not reach every item.
fn walk(
    count: usize,
    end: Option<usize>,
    any: usize,
    nbrs: impl Fn(usize) -> Vec<usize>,
) -> Option<(Vec<usize>, bool)> {
    let start = end.unwrap_or(any);
    let mut order = vec![start];
    let mut prev = usize::MAX;
    let mut closed = false;
    while let Some(next) = nbrs(order[order.len() - 1]).into_iter().find(|&u| u != prev) {
        if next == start && end.is_none() && order.len() > 2 {
            closed = true;
            break;
        }
        if order.len() >= count {
            return None;
        }
        prev = order[order.len() - 1];
        order.push(next);
    }
    (order.len() == count && (closed || end.is_some())).then_some((order, closed))
}

/// Every region of `w` that is a strip of at least [`MIN_TRIANGLES`] triangles, in region
/// order: a region whose units (see [`Strip`]) form one path or one cycle.
pub(super) fn strips(w: &SurfaceWork) -> Vec<Strip> {
    let topo = &w.topo;
    let degree = |t: usize| topo.nbr[3 * t..3 * t + 3].iter().filter(|&&u| u != NONE).count();
    let n_regions = w.n_regions;
    // speed: a region with a triangle of three neighbours none of which is a leaf is no
    // strip (the first such triangle of a large surface ends its scan)
    let mut wide = vec![false; n_regions];
    for t in 0..topo.len() {
        let r = w.region[t] as usize;
        if r < n_regions
            && !wide[r]
            && degree(t) == 3
            && topo.nbr[3 * t..3 * t + 3].iter().all(|&u| degree(u as usize) > 1)
        {
            wide[r] = true;
        }
    }
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); n_regions];
    for t in 0..topo.len() {
        let r = w.region[t] as usize;
        if r < n_regions && !wide[r] {
            members[r].push(t);
        }
    }
    members
        .iter()
        .filter(|m| m.len() >= MIN_TRIANGLES)
        .filter_map(|m| units(topo, m, &degree))
        .collect()
}

/// The units of the region `members` as a path or cycle, or `None` when they do not form
/// one: a triangle whose three neighbours all have others, or a unit with three
/// neighbouring units.
fn units(topo: &SurfaceTopo, members: &[usize], degree: &impl Fn(usize) -> usize) -> Option<Strip> {
    let nbrs = |t: usize| {
        topo.nbr[3 * t..3 * t + 3]
            .iter()
            .filter(|&&u| u != NONE)
            .map(|&u| u as usize)
    };
    // a leaf (one neighbour) joins its neighbour's unit when that neighbour has three
    let absorbed = |t: usize| degree(t) == 1 && nbrs(t).all(|u| degree(u) == 3);
    let mut unit_of: std::collections::HashMap<usize, usize> = std::collections::HashMap::new();
    let mut list: Vec<Vec<usize>> = Vec::new();
    for &t in members {
        if absorbed(t) {
            continue;
        }
        let mut unit = vec![t];
        unit.extend(nbrs(t).filter(|&u| absorbed(u)));
        for &u in &unit {
            unit_of.insert(u, list.len());
        }
        list.push(unit);
    }
    if unit_of.len() != members.len() {
        return None;
    }
    // each unit's neighbouring units
    let next: Vec<Vec<usize>> = list
        .iter()
        .map(|unit| {
            let mut out: Vec<usize> = unit
                .iter()
                .flat_map(|&t| nbrs(t))
                .filter_map(|u| unit_of.get(&u).copied())
                .filter(|&v| v != unit_of[&unit[0]])
                .collect();
            out.sort_unstable();
            out.dedup();
            out
        })
        .collect();
    if next.iter().any(|v| v.len() > 2) {
        return None;
    }
    let count = list.len();
    let end = (0..count).find(|&u| next[u].len() < 2);
    let (order, closed) = walk(count, end, 0, |u| next[u].clone())?;
    Some(Strip {
        units: order.iter().map(|&u| list[u].clone()).collect(),
        closed,
    })
}

/// Smallest strip [`plans`] looks at: two cells.
const MIN_TRIANGLES: usize = 4;

/// A strip whose quads from the matching have a worst η (eq. 3) below this is meshed again
/// when [`plans`] finds a better worst quad.
pub(super) const REMESH_BELOW: f64 = 0.3;

/// How much better (in η) the remeshed strip's worst quad must be than the matching's.
pub(super) const MIN_GAIN: f64 = 0.05;

/// A vertex of a cell: a node id, or the midline node of rung `k` ([`MID`] + k).
type Vertex = u64;

/// Vertices at or above this are midline nodes: `MID + k` sits at the midpoint of rung `k`.
const MID: u64 = 1 << 40;

/// A cell's quads (vertices) and their worst η, or `None` when the cell cannot be cut
/// into sound quads that way.
type CellQuads = Option<(Vec<[Vertex; 4]>, f64)>;

/// The geometry of one strip: its units' triangles (node ids, in strip order), rungs and
/// positions.
struct StripGeometry<'a> {
    units: Vec<Vec<[u32; 3]>>,
    /// `rung[k]`: the edge between unit `k` and `k + 1` (cyclically on a band).
    rung: Vec<(u32, u32)>,
    /// The sum of each unit's triangles' unit normals.
    normal: Vec<DVec3>,
    coords: &'a [DVec3],
    closed: bool,
}

impl StripGeometry<'_> {
    fn pos(&self, v: Vertex) -> DVec3 {
        if v >= MID {
            let (a, b) = self.rung[(v - MID) as usize];
            0.5 * (self.coords[a as usize] + self.coords[b as usize])
        } else {
            self.coords[v as usize]
        }
    }

    fn len(&self) -> usize {
        self.units.len()
    }

    /// The number of triangles of the cell of `size` units from position `at`.
    fn triangles(&self, at: usize, size: usize) -> usize {
        (at..at + size).map(|k| self.units[k % self.len()].len()).sum()
    }

    /// The quads of the cell of `size` units from strip position `at` (cyclic on a band),
    /// with a midline node on its first rung when `open_in` and on its last when
    /// `open_out`: a polygon of four vertices is one quad; one of six is cut into two along
    /// the diagonal between opposite vertices that gives the better worst η.
    fn cell(&self, at: usize, size: usize, open_in: bool, open_out: bool) -> CellQuads {
        let n = self.len();
        let mut poly: Vec<Vertex> = Vec::new();
        for k in at..at + size {
            for t in &self.units[k % n] {
                let t = t.map(u64::from);
                poly = if poly.is_empty() {
                    t.to_vec()
                } else {
                    merge(&poly, &t)?
                };
            }
        }
        // a cell that closes on itself (a whole short band) is no polygon
        let mut sorted = poly.clone();
        sorted.sort_unstable();
        if sorted.windows(2).any(|w| w[0] == w[1]) {
            return None;
        }
        let mut normal = DVec3::ZERO;
        for k in at..at + size {
            normal += self.normal[k % n];
        }
        if open_in {
            let k = (at + n - 1) % n;
            insert_mid(&mut poly, self.rung[k], MID + k as u64)?;
        }
        if open_out {
            let k = (at + size - 1) % n;
            insert_mid(&mut poly, self.rung[k], MID + k as u64)?;
        }
        let eta = |q: &[Vertex; 4]| crate::quality::eta_signed(&q.map(|v| self.pos(v)), normal);
        match poly.len() {
            4 => {
                let q = [poly[0], poly[1], poly[2], poly[3]];
                let e = eta(&q);
                Some((vec![q], e))
            }
            6 => (0..3)
                .map(|j| {
                    let p = |o: usize| poly[(j + o) % 6];
                    let a = [p(0), p(1), p(2), p(3)];
                    let b = [p(3), p(4), p(5), p(0)];
                    let e = eta(&a).min(eta(&b));
                    (vec![a, b], e)
                })
                .max_by(|x, y| x.1.total_cmp(&y.1)),
            _ => None,
        }
    }
}

/// Inserts `m` between the two vertices of `poly` that make the edge `e` (either way).
fn insert_mid(poly: &mut Vec<Vertex>, e: (u32, u32), m: Vertex) -> Option<()> {
    let (a, b) = (u64::from(e.0), u64::from(e.1));
    let n = poly.len();
    let i = (0..n).find(|&i| {
        let (p, q) = (poly[i], poly[(i + 1) % n]);
        (p == a && q == b) || (p == b && q == a)
    })?;
    poly.insert(i + 1, m);
    Some(())
}

/// Largest cell, in units.
const MAX_CELL: usize = 4;

/// One step of the strip's plan: a cell of `size` units, and its quads.
#[derive(Clone)]
struct Step {
    size: usize,
    quads: Vec<[Vertex; 4]>,
}

/// Every cell of `g` that a plan may take ([`StripGeometry::cell`]), computed once for
/// the passes of [`best_plan`]: on a band, fewer units than the band; on a path, within it,
/// with a midline node only on a rung it has. Others are `None`.
struct Cells(Vec<CellQuads>);

impl Cells {
    fn new(g: &StripGeometry) -> Self {
        let mut all = Vec::with_capacity(g.len() * MAX_CELL * 4);
        for at in 0..g.len() {
            for size in 1..=MAX_CELL {
                for (open_in, open_out) in [(false, false), (false, true), (true, false), (true, true)]
                {
                    let n = g.len();
                    let fits = if g.closed {
                        size < n
                    } else {
                        at + size <= n && !(open_in && at == 0) && !(open_out && at + size == n)
                    };
                    all.push(fits.then(|| g.cell(at, size, open_in, open_out)).flatten());
                }
            }
        }
        Cells(all)
    }

    fn at(&self, at: usize, size: usize, open_in: bool, open_out: bool) -> &CellQuads {
        &self.0[(at * MAX_CELL + size - 1) * 4 + 2 * usize::from(open_in) + usize::from(open_out)]
    }
}

/// The best plan of `g` (its cells `cells`) from position `start` round (or along) the
/// strip with the rung before `start` in state `open` (a band comes back to the same
/// state), by worst η first and then by the fewest quads (the sum of `1 + (1 − η)` over
/// quads at least `floor`). With `floor` set, cells with a quad under it are not taken.
/// Returns the plan's worst η and its steps.
fn plan(
    g: &StripGeometry,
    cells: &Cells,
    start: usize,
    open: bool,
    floor: Option<f64>,
) -> Option<(f64, Vec<Step>)> {
    let n = g.len();
    // best[k][o]: (worst η, cost, step, previous state) of the first k units with the rung
    // after them in state o
    type Entry = Option<(f64, f64, Step, bool)>;
    let mut best: Vec<[Entry; 2]> = vec![[None, None]; n + 1];
    let value = |k: usize, o: bool, best: &Vec<[Entry; 2]>| -> Option<(f64, f64)> {
        if k == 0 {
            return (o == open).then_some((f64::INFINITY, 0.0));
        }
        best[k][o as usize].as_ref().map(|e| (e.0, e.1))
    };
    for k in 0..n {
        for o in [false, true] {
            let Some((worst, cost)) = value(k, o, &best) else {
                continue;
            };
            // a path has no rung before its first triangle
            if o && k == 0 && !g.closed {
                continue;
            }
            let at = (start + k) % n;
            for size in 1..=MAX_CELL.min(n - k) {
                let out = o ^ (g.triangles(at, size) % 2 == 1);
                let end = k + size == n;
                if end && !g.closed && out {
                    continue;
                }
                if end && g.closed && out != open {
                    continue;
                }
                let Some((quads, eta)) = cells.at(at, size, o, out) else {
                    continue;
                };
                let eta = *eta;
                if floor.is_some_and(|f| eta < f) {
                    continue;
                }
                let q = quads.len() as f64;
                let c = cost + q * (2.0 - eta.max(0.0));
                let w = worst.min(eta);
                let slot = &mut best[k + size][out as usize];
                let better = match slot {
                    None => true,
                    Some((bw, bc, ..)) => match floor {
                        Some(_) => c < *bc,
                        None => w > *bw || (w == *bw && c < *bc),
                    },
                };
                if better {
                    let quads = quads.clone();
                    *slot = Some((w, c, Step { size, quads }, o));
                }
            }
        }
    }
    let (worst, ..) = best[n][open as usize].as_ref()?;
    let worst = *worst;
    let mut steps = Vec::new();
    let (mut k, mut o) = (n, open);
    while k > 0 {
        let (_, _, step, prev) = best[k][o as usize].as_ref()?;
        k -= step.size;
        o = *prev;
        steps.push(step.clone());
    }
    steps.reverse();
    Some((worst, steps))
}

/// The best plan of the strip over its starting positions and states (a band is cut at
/// one of its first [`MAX_CELL`] rungs, so every cell fits in some cut), worst η first,
/// then the fewest quads at a worst η of at least the best's capped at [`REMESH_BELOW`].
fn best_plan(g: &StripGeometry) -> Option<(f64, usize, Vec<Step>)> {
    let starts: Vec<(usize, bool)> = if g.closed {
        (0..MAX_CELL.min(g.len()))
            .flat_map(|s| [(s, false), (s, true)])
            .collect()
    } else {
        vec![(0, false)]
    };
    let cells = Cells::new(g);
    let worst = starts
        .iter()
        .filter_map(|&(s, o)| plan(g, &cells, s, o, None).map(|p| p.0))
        .fold(f64::NEG_INFINITY, f64::max);
    if !worst.is_finite() {
        return None;
    }
    let floor = worst.min(REMESH_BELOW) - 1e-12;
    starts
        .iter()
        .filter_map(|&(s, o)| {
            let (w, steps) = plan(g, &cells, s, o, Some(floor))?;
            let quads: usize = steps.iter().map(|st| st.quads.len()).sum();
            Some((w, s, steps, quads))
        })
        .min_by(|a, b| a.3.cmp(&b.3).then(b.0.total_cmp(&a.0)))
        .map(|(w, s, steps, _)| (w, s, steps))
}

/// A strip's new mesh, before it replaces the matching's quads ([`apply`]).
#[derive(Debug, Clone)]
pub(crate) struct StripPlan {
    /// The strip's index in the surface's strips.
    pub strip: usize,
    /// The worst η of the matching's quads of the strip.
    pub worst_before: f64,
    /// The worst η of the new quads.
    pub worst_after: f64,
    /// New quads less the matching's quads of the strip.
    pub extra_quads: usize,
    /// The new quads (node ids, or [`MID`] + rung for a midline node) and the triangle
    /// whose element tag each takes.
    quads: Vec<([Vertex; 4], u32)>,
    /// The midline nodes: vertex, position and the rung's two nodes, in vertex order.
    mids: Vec<(Vertex, DVec3, [u32; 2])>,
}

impl StripPlan {
    /// The plan with every node id `v` in it (midline nodes aside) replaced by `f(v)`;
    /// `None` when `f` gives none for one of them.
    pub(super) fn with_ids(&self, f: impl Fn(u32) -> Option<u32>) -> Option<StripPlan> {
        let node = |v: Vertex| -> Option<Vertex> {
            if v >= MID {
                Some(v)
            } else {
                f(u32::try_from(v).ok()?).map(Vertex::from)
            }
        };
        let quads = self
            .quads
            .iter()
            .map(|&(q, src)| {
                let mut out = q;
                for v in &mut out {
                    *v = node(*v)?;
                }
                Some((out, src))
            })
            .collect::<Option<Vec<_>>>()?;
        let mids = self
            .mids
            .iter()
            .map(|&(v, p, [a, b])| Some((v, p, [f(a)?, f(b)?])))
            .collect::<Option<Vec<_>>>()?;
        Some(StripPlan {
            strip: self.strip,
            worst_before: self.worst_before,
            worst_after: self.worst_after,
            extra_quads: self.extra_quads,
            quads,
            mids,
        })
    }
}

/// For each strip of `strips` (of the surface of `topo`) whose quads in `faces` (the
/// matching's) have a worst η below [`REMESH_BELOW`], the plan of cells and midlines (see
/// the module docs) with the best worst quad, when that is at least [`MIN_GAIN`] better
/// (and above η 0 by as much).
pub(super) fn plans(
    topo: &SurfaceTopo,
    strips: &[Strip],
    coords: &[DVec3],
    faces: &Faces,
    n_global: u32,
) -> Vec<StripPlan> {
    if strips.is_empty() {
        return Vec::new();
    }
    let unit_normal = |t: &[u32; 3]| {
        let p = t.map(|v| coords[v as usize]);
        (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero()
    };
    let strip_of = strip_of(topo.len(), strips);
    // the worst of the matching's quads of each strip, and their number
    let at = |v: u32| match v.checked_sub(n_global) {
        Some(j) => faces.new_nodes[j as usize].pos,
        None => coords[v as usize],
    };
    let mut worst = vec![f64::INFINITY; strips.len()];
    let mut count = vec![0usize; strips.len()];
    for (q, &src) in faces.quads.iter().zip(&faces.source) {
        let i = strip_of[src as usize];
        if i == u32::MAX {
            continue;
        }
        let e = crate::quality::eta_signed(&q.map(at), unit_normal(&topo.tris[src as usize]));
        worst[i as usize] = worst[i as usize].min(e);
        count[i as usize] += 1;
    }
    let mut out = Vec::new();
    for (i, s) in strips.iter().enumerate() {
        if worst[i] >= REMESH_BELOW {
            continue;
        }
        let n = s.units.len();
        let units: Vec<Vec<[u32; 3]>> = s
            .units
            .iter()
            .map(|u| u.iter().map(|&t| topo.tris[t]).collect())
            .collect();
        let rungs = if s.closed { n } else { n - 1 };
        let rung: Option<Vec<(u32, u32)>> = (0..rungs)
            .map(|k| shared_edge(&units[k], &units[(k + 1) % n]))
            .collect();
        let Some(rung) = rung else { continue };
        let g = StripGeometry {
            normal: units
                .iter()
                .map(|u| u.iter().map(unit_normal).sum())
                .collect(),
            units,
            rung,
            coords,
            closed: s.closed,
        };
        let Some((eta, start, steps)) = best_plan(&g) else {
            continue;
        };
        if eta < worst[i].max(0.0) + MIN_GAIN {
            continue;
        }
        let mut mids: Vec<Vertex> = steps
            .iter()
            .flat_map(|st| st.quads.iter().flatten())
            .copied()
            .filter(|&v| v >= MID)
            .collect();
        mids.sort_unstable();
        mids.dedup();
        let mut quads = Vec::new();
        let mut at = start;
        for step in &steps {
            // each quad takes a triangle of its cell that no other quad takes
            let cell = (at..at + step.size).flat_map(|k| &s.units[k % n]);
            for (q, &src) in step.quads.iter().zip(cell) {
                quads.push((*q, src as u32));
            }
            at += step.size;
        }
        out.push(StripPlan {
            strip: i,
            worst_before: worst[i],
            worst_after: eta,
            extra_quads: quads.len().saturating_sub(count[i]),
            quads,
            mids: mids
                .into_iter()
                .map(|v| {
                    let (a, b) = g.rung[(v - MID) as usize];
                    (v, g.pos(v), [a, b])
                })
                .collect(),
        });
    }
    out
}

/// Each triangle's strip in `strips`, or `u32::MAX`.
fn strip_of(triangles: usize, strips: &[Strip]) -> Vec<u32> {
    let mut out = vec![u32::MAX; triangles];
    for (i, s) in strips.iter().enumerate() {
        for &t in s.units.iter().flatten() {
            out[t] = i as u32;
        }
    }
    out
}

/// Replaces, in `faces` (a surface of `triangles` triangles whose strips are `strips`),
/// the quads of each planned strip by its plan's quads: the midline nodes join
/// `faces.new_nodes`, and the nodes of vertex duplications that only the strip's old quads
/// used go (the others keep their order, renumbered).
pub(super) fn apply(
    faces: &mut Faces,
    triangles: usize,
    strips: &[Strip],
    plans: &[&StripPlan],
    n_global: u32,
) {
    if plans.is_empty() {
        return;
    }
    let strip_of = strip_of(triangles, strips);
    let mut remeshed = vec![false; strips.len()];
    let mut quads = Vec::with_capacity(faces.quads.len());
    let mut source = Vec::with_capacity(faces.quads.len());
    for p in plans {
        remeshed[p.strip] = true;
    }
    for (q, &src) in faces.quads.iter().zip(&faces.source) {
        let i = strip_of[src as usize];
        if i != u32::MAX && remeshed[i as usize] {
            continue;
        }
        quads.push(*q);
        source.push(src);
    }
    for p in plans {
        let first = n_global + faces.new_nodes.len() as u32;
        for &(_, pos, near) in &p.mids {
            faces.new_nodes.push(NewNode {
                pos,
                near: near.to_vec(),
            });
        }
        let id = |v: Vertex| -> u32 {
            if v >= MID {
                let j = p.mids.binary_search_by_key(&v, |m| m.0).unwrap_or(0);
                first + j as u32
            } else {
                v as u32
            }
        };
        for &(q, src) in &p.quads {
            quads.push(q.map(id));
            source.push(src);
        }
    }
    // the nodes of vertex duplications in a remeshed strip go, the others are renumbered
    let mut used = vec![false; faces.new_nodes.len()];
    for &v in quads.iter().flatten() {
        if let Some(j) = v.checked_sub(n_global) {
            used[j as usize] = true;
        }
    }
    let mut new_id = vec![u32::MAX; used.len()];
    let mut kept = Vec::with_capacity(used.len());
    for (j, node) in std::mem::take(&mut faces.new_nodes).into_iter().enumerate() {
        if used[j] {
            new_id[j] = n_global + kept.len() as u32;
            kept.push(node);
        } else {
            faces.duplications = faces.duplications.saturating_sub(1);
        }
    }
    for v in quads.iter_mut().flatten() {
        if let Some(j) = v.checked_sub(n_global) {
            *v = new_id[j as usize];
        }
    }
    faces.new_nodes = kept;
    faces.quads = quads;
    faces.source = source;
}

/// The edge that a triangle of unit `a` shares with a triangle of unit `b`, as its two
/// node ids.
fn shared_edge(a: &[[u32; 3]], b: &[[u32; 3]]) -> Option<(u32, u32)> {
    a.iter().find_map(|ta| {
        b.iter().find_map(|tb| {
            (0..3).find_map(|k| {
                let (p, q) = (ta[k], ta[(k + 1) % 3]);
                (tb.contains(&p) && tb.contains(&q)).then_some((p, q))
            })
        })
    })
}

/// The worst η (eq. 3, signed) of the best plan of the open strip `strip` of `topo` without
/// a midline (cells of even triangle counts, one quad per two triangles); `None` when there
/// is none. `coords` are the positions of `topo`'s node ids.
pub(super) fn no_midline_worst(topo: &SurfaceTopo, strip: &Strip, coords: &[DVec3]) -> Option<f64> {
    if strip.closed {
        return None;
    }
    let units: Vec<Vec<[u32; 3]>> = strip
        .units
        .iter()
        .map(|u| u.iter().map(|&t| topo.tris[t]).collect())
        .collect();
    let rung: Option<Vec<(u32, u32)>> = units.windows(2).map(|w| shared_edge(&w[0], &w[1])).collect();
    let unit_normal = |t: &[u32; 3]| {
        let p = t.map(|v| coords[v as usize]);
        (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero()
    };
    let g = StripGeometry {
        normal: units.iter().map(|u| u.iter().map(unit_normal).sum()).collect(),
        units,
        rung: rung?,
        coords,
        closed: false,
    };
    // best[k]: the best worst η of the first k units cut into cells of even counts
    let n = g.len();
    let mut best = vec![f64::NEG_INFINITY; n + 1];
    best[0] = f64::INFINITY;
    for k in 0..n {
        if best[k] == f64::NEG_INFINITY {
            continue;
        }
        for size in 1..=MAX_CELL.min(n - k) {
            if g.triangles(k, size).is_multiple_of(2) {
                if let Some((_, eta)) = g.cell(k, size, false, false) {
                    best[k + size] = best[k + size].max(best[k].min(eta));
                }
            }
        }
    }
    (best[n] > f64::NEG_INFINITY).then_some(best[n])
}
