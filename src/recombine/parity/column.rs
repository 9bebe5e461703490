//! Splits placed in pairs across a strip. When the plan runs a parity fix through a strip
//! (a region whose every triangle has a wall edge, such as the narrow face between the two
//! big faces of a thin plate), two chosen groups flip that region, one on each of its
//! curves. Two splits placed independently leave the strip's few perfect matchings (a path
//! has one) pairing the two halves of a split triangle into a quad with a straight angle at
//! the new node. Instead, the two segments are taken on opposite sides of one interior edge
//! `b`–`c` of the strip, and after the splits that edge is flipped to join the two new nodes:
//! the strip gains a column of alternating triangles, which pairs into sound quads whichever
//! way the rest of the strip is matched ([`columns`]). An odd strip flipped once gets the
//! split that its forced matching pairs best ([`place_single_splits`]), and the T-join
//! prices curves whose every split spoils an odd strip above one split ([`group_costs`]).

use super::*;
use crate::recombine::strip::strip_order;

/// Two segments split together across a strip, and the edge flipped after the splits.
#[derive(Debug, Clone)]
pub(crate) struct Column {
    /// Tag of the strip's surface.
    pub surface: i32,
    /// Global ids of the first segment's ends (a wall edge of triangle `T`).
    pub first: (u32, u32),
    /// Global ids of the second segment's ends (a wall edge of `U`, `T`'s neighbour).
    pub second: (u32, u32),
    /// The edge `T` and `U` share: `b` on the first segment, `c` on the second.
    pub b: u32,
    /// See `b`.
    pub c: u32,
}

/// A wall segment of the plan that [`columns`] and [`place_single_splits`] may choose.
#[derive(Debug, Clone, Copy)]
pub(super) struct Segment {
    /// Edge key.
    pub key: u64,
    /// The group it belongs to.
    pub group: usize,
    /// Not in the plan's `avoid` list.
    pub wanted: bool,
    /// No triangle on it is near an ear.
    pub no_ear: bool,
}

/// For each region flipped by exactly two of the `chosen` groups (each a plain segment
/// group: no periodic images, no quad chord) that is a strip, picks the two groups'
/// segments as a [`Column`] and makes them the groups' `best`. `segments` is sorted by key.
/// A group takes part in one column at most; a region with no fitting pair of triangles
/// keeps the groups' own choices.
pub(super) fn columns(
    work: &[SurfaceWork],
    offset: &[u32],
    nodes: &NodeTable,
    list: &mut [Group],
    chosen: &[usize],
    segments: &[Segment],
) -> Vec<Column> {
    let mut by_region: HashMap<u32, Vec<usize>> = HashMap::new();
    for &g in chosen.iter().filter(|&&g| plain(list, g)) {
        for &r in &list[g].sig {
            by_region.entry(r).or_default().push(g);
        }
    }
    let mut regions: Vec<(u32, usize, usize)> = by_region
        .into_iter()
        .filter(|(_, gs)| gs.len() == 2)
        .map(|(r, gs)| (r, gs[0], gs[1]))
        .collect();
    regions.sort_unstable();
    let mut used = vec![false; list.len()];
    let mut out = Vec::new();
    for (r, g1, g2) in regions {
        if used[g1] || used[g2] {
            continue;
        }
        let (w, local) = region_of(work, offset, r);
        let Some((col, _)) = best_column(w, local, nodes, segments, g1, g2) else {
            continue;
        };
        used[g1] = true;
        used[g2] = true;
        for (g, (a, b)) in [(g1, col.first), (g2, col.second)] {
            let len = (nodes.coords[a as usize] - nodes.coords[b as usize]).length();
            list[g].best = (true, true, len, a, b);
        }
        out.push(col);
    }
    out
}

/// For each region flipped by one chosen group only, that is a strip whose triangles form
/// a path (such as a narrow face between two curves, open at both ends), moves the group's
/// split to the segment that gives the best worst quad in the strip. A path has one perfect
/// matching, so where the split lands decides every pair: a split triangle with an even
/// number of triangles before it has its two halves paired into a quad with a straight
/// angle at the new node, and the place shifts the pairs on either side of it, which may
/// pair two triangles of a fan into a quad flat at a boundary node. A group that flips
/// several such strips takes the segment whose worst quad over all of them is best; it
/// keeps its own choice unless another is better. Groups of `columns` are left alone.
pub(super) fn place_single_splits(
    work: &[SurfaceWork],
    offset: &[u32],
    nodes: &NodeTable,
    list: &mut [Group],
    chosen: &[usize],
    segments: &[Segment],
    columns: &[Column],
) {
    let mut flips: HashMap<u32, Vec<usize>> = HashMap::new();
    for &g in chosen {
        for &r in &list[g].sig {
            flips.entry(r).or_default().push(g);
        }
    }
    let in_column = |g: usize| {
        let key = edge_key(list[g].best.3, list[g].best.4);
        columns.iter().any(|c| {
            [c.first, c.second]
                .iter()
                .any(|&(x, y)| edge_key(x, y) == key)
        })
    };
    let mut regions: Vec<(u32, usize)> = flips
        .into_iter()
        .filter(|(_, gs)| gs.len() == 1)
        .map(|(r, gs)| (r, gs[0]))
        .filter(|&(_, g)| plain(list, g) && !in_column(g))
        .collect();
    regions.sort_unstable();
    // per group: segment key → worst quad over its strips when that segment is split
    let mut worst: HashMap<usize, HashMap<u64, f64>> = HashMap::new();
    for (r, g) in regions {
        let (w, local) = region_of(work, offset, r);
        let Some((path, closed)) = strip_order(w, local) else {
            continue;
        };
        let scores = worst.entry(g).or_default();
        // any plain group flipping the same regions will do as well as `g`
        let same = |h: usize| h == g || (list[h].sig == list[g].sig && plain(list, h));
        for (key, eta) in split_scores(w, nodes, &path, closed, |key| {
            segment(segments, key).is_some_and(|(h, _)| same(h))
        }) {
            let e = scores.entry(key).or_insert(f64::INFINITY);
            *e = e.min(eta);
        }
    }
    let mut groups: Vec<(usize, HashMap<u64, f64>)> = worst.into_iter().collect();
    groups.sort_unstable_by_key(|x| x.0);
    for (g, scores) in groups {
        let best = list[g].best;
        let now = scores
            .get(&edge_key(best.3, best.4))
            .copied()
            .unwrap_or(f64::NEG_INFINITY);
        // in key order, so that of equal candidates the same one is taken on every run
        let mut candidates: Vec<(u64, f64)> = scores.into_iter().collect();
        candidates.sort_unstable_by_key(|c| c.0);
        let pick = candidates
            .iter()
            .filter(|&&(_, eta)| eta > now + 1e-9)
            .filter_map(|&(key, eta)| {
                let p = segments.binary_search_by_key(&key, |s| s.key).ok()?;
                let sgm = segments[p];
                let (a, b) = ((key >> 32) as u32, key as u32);
                let len = (nodes.coords[a as usize] - nodes.coords[b as usize]).length();
                Some(((eta, sgm.wanted, sgm.no_ear, len), a, b, sgm.group))
            })
            .max_by(|x, y| x.0.partial_cmp(&y.0).unwrap_or(std::cmp::Ordering::Equal));
        if let Some(((_, wanted, no_ear, len), a, b, h)) = pick {
            list[g].best = (wanted, no_ear, len, a, b);
            list[g].curve = list[h].curve;
        }
    }
}

/// Longest closed band whose splits [`split_scores`] weighs (each weighing walks the band).
const BAND_MAX: usize = 2000;

/// For each wall segment accepted by `wanted` on a triangle of the odd path `path`, the
/// worst η (eq. 3, signed) of the path's one perfect matching once that segment is split:
/// the pairs before the split triangle, the two quads its halves make with their
/// neighbours, the pairs after it. A split triangle with an even number of triangles
/// before it scores −1 (its halves are paired together, flat at the new node). On a
/// `closed` band (an odd cycle, at most [`BAND_MAX`] triangles) the split makes an even
/// cycle, whose two perfect matchings are its two alternations: the one that keeps the
/// halves apart is weighed.
fn split_scores(
    w: &SurfaceWork,
    nodes: &NodeTable,
    path: &[usize],
    closed: bool,
    wanted: impl Fn(u64) -> bool,
) -> Vec<(u64, f64)> {
    let n = path.len();
    if n.is_multiple_of(2) || (closed && n > BAND_MAX) {
        return Vec::new();
    }
    let tri = |k: usize| w.topo.tris[path[k]];
    let at = |v: u32| nodes.coords[v as usize];
    let pair = |k: usize| {
        pair_eta(
            &tri(k).map(|v| (v, at(v))),
            &tri((k + 1) % n).map(|v| (v, at(v))),
        )
    };
    // on a band: the pair of each triangle with the next one round it
    let round: Vec<f64> = if closed {
        (0..n).map(pair).collect()
    } else {
        Vec::new()
    };
    // on a path: before[j], the worst of the pairs (0,1) … (2j−2, 2j−1); after[j], the
    // worst of the pairs (2j+1, 2j+2) … (n−2, n−1)
    let (mut before, mut after) = (Vec::new(), Vec::new());
    if !closed {
        before = vec![f64::INFINITY; n / 2 + 1];
        for j in 0..n / 2 {
            before[j + 1] = before[j].min(pair(2 * j));
        }
        after = vec![f64::INFINITY; n / 2 + 1];
        for j in (0..n / 2).rev() {
            after[j] = after[j + 1].min(pair(2 * j + 1));
        }
    }
    let mut out = Vec::new();
    for (i, &t) in path.iter().enumerate() {
        let tr = tri(i);
        for k in 0..3 {
            if w.topo.nbr[3 * t + k] != NONE {
                continue;
            }
            let (x, y, z) = (tr[k], tr[(k + 1) % 3], tr[(k + 2) % 3]);
            let key = edge_key(x, y);
            if !wanted(key) {
                continue;
            }
            if i % 2 == 0 && !closed {
                out.push((key, -1.0));
                continue;
            }
            // the halves (x, m, z) and (m, y, z), m a node of its own
            let m = (u32::MAX, 0.5 * (at(x) + at(y)));
            let halves = [[(x, at(x)), m, (z, at(z))], [m, (y, at(y)), (z, at(z))]];
            let prev = tri((i + n - 1) % n).map(|v| (v, at(v)));
            let next = tri((i + 1) % n).map(|v| (v, at(v)));
            let near = |h: &[(u32, DVec3); 3], o: &[(u32, DVec3); 3]| {
                h.iter().filter(|a| o.iter().any(|b| b.0 == a.0)).count() == 2
            };
            let (ha, hb) = if near(&halves[0], &prev) {
                (halves[0], halves[1])
            } else {
                (halves[1], halves[0])
            };
            let rest = if closed {
                // the pairs (i + 2, i + 3), (i + 4, i + 5), … round the band to i − 1
                (0..(n - 3) / 2)
                    .map(|s| round[(i + 2 + 2 * s) % n])
                    .fold(f64::INFINITY, f64::min)
            } else {
                before[i / 2].min(after[i / 2 + 1])
            };
            let eta = rest.min(pair_eta(&prev, &ha)).min(pair_eta(&hb, &next));
            out.push((key, eta));
        }
    }
    out
}

/// Signed η ([`crate::quality::eta_signed`]) of the quad made of two oriented triangles
/// sharing an edge, given as (node, position); −1 when they share no edge.
pub(super) fn pair_eta(a: &[(u32, DVec3); 3], b: &[(u32, DVec3); 3]) -> f64 {
    for k in 0..3 {
        let (p, q, r) = (a[k], a[(k + 1) % 3], a[(k + 2) % 3]);
        for j in 0..3 {
            if b[j].0 == q.0 && b[(j + 1) % 3].0 == p.0 {
                let s = b[(j + 2) % 3];
                let quad = [p.1, s.1, q.1, r.1];
                let normal = (q.1 - p.1).cross(r.1 - p.1).normalize_or_zero()
                    + (p.1 - q.1).cross(s.1 - q.1).normalize_or_zero();
                return crate::quality::eta_signed(&quad, normal);
            }
        }
    }
    -1.0
}

/// What one split costs in the parity plan's T-join ([`group_costs`]).
pub(super) const SPLIT_COST: i64 = 2;

/// What a split costs on top of [`SPLIT_COST`] when it lands on an odd strip where every
/// segment of its group leaves the strip's forced matching a quad that is not valid (η
/// below 0): the plan then takes a path one split longer to split a better curve.
const INVALID_STRIP_COST: i64 = 3;

/// What a split costs on top of [`SPLIT_COST`] when the best its group can do on an odd
/// strip is a worst quad under [`STRIP_ETA`] (but valid).
const POOR_STRIP_COST: i64 = 1;

/// The worst quad η below which a split on an odd strip counts as poor ([`group_costs`]).
const STRIP_ETA: f64 = 0.2;

/// What a split costs on top of [`SPLIT_COST`] when it lands on the wall of an odd closed
/// band that has more segments than the band's other wall: a band one triangle wide pairs
/// into quads that each join a segment of one wall to a segment of the other, so the split
/// on the shorter wall evens the two out and the one on the longer wall leaves them two
/// apart (the band's strip plan then needs a midline, see `recombine::strip`).
const LONGER_WALL_COST: i64 = 1;

/// The T-join cost of each group of `list`: [`SPLIT_COST`], plus [`INVALID_STRIP_COST`] or
/// [`POOR_STRIP_COST`] when the group flips an odd strip (a path or a closed band, see
/// [`place_single_splits`]) on which none of its plain segments gives the strip's forced
/// matching a valid worst quad, or one of at least [`STRIP_ETA`], plus [`LONGER_WALL_COST`]
/// when its segments on an odd closed band all lie on the band's longer wall. So between
/// two curves of an odd strip, such as the inner and outer circle of a coarse annulus, the
/// plan splits the one whose split lets the strip pair into sound quads.
pub(super) fn group_costs(
    work: &[SurfaceWork],
    offset: &[u32],
    nodes: &NodeTable,
    list: &[Group],
    segments: &[Segment],
    odd_in: &[bool],
) -> Vec<i64> {
    let mut cost = vec![SPLIT_COST; list.len()];
    let mut best: HashMap<usize, f64> = HashMap::new();
    // groups with a segment on the shorter wall of an odd band, and with one on the longer
    let (mut shorter, mut longer) = (vec![false; list.len()], vec![false; list.len()]);
    for (r, _) in odd_in.iter().enumerate().filter(|x| *x.1) {
        let r = r as u32;
        let (w, local) = region_of(work, offset, r);
        let Some((path, closed)) = strip_order(w, local) else {
            continue;
        };
        if closed {
            for (key, on_longer) in band_walls(w, &path) {
                if let Some((g, _)) = segment(segments, key).filter(|&(g, _)| plain(list, g)) {
                    if on_longer {
                        longer[g] = true;
                    } else {
                        shorter[g] = true;
                    }
                }
            }
        }
        let scores = split_scores(w, nodes, &path, closed, |key| {
            segment(segments, key).is_some_and(|(g, _)| plain(list, g))
        });
        let mut here: HashMap<usize, f64> = HashMap::new();
        for (key, eta) in scores {
            if let Some((g, _)) = segment(segments, key) {
                let e = here.entry(g).or_insert(f64::NEG_INFINITY);
                *e = e.max(eta);
            }
        }
        for (g, eta) in here {
            let e = best.entry(g).or_insert(f64::INFINITY);
            *e = e.min(eta);
        }
    }
    for (g, eta) in best {
        if eta < 0.0 {
            cost[g] += INVALID_STRIP_COST;
        } else if eta < STRIP_ETA {
            cost[g] += POOR_STRIP_COST;
        }
    }
    for g in 0..list.len() {
        if longer[g] && !shorter[g] {
            cost[g] += LONGER_WALL_COST;
        }
    }
    cost
}

/// The wall segments (edge keys) of the closed band whose triangles are `path` (one row:
/// every triangle has a wall edge), each with whether it lies on the band's longer wall:
/// the band's walls are the two loops its wall segments make, and the longer one has more
/// segments. Empty when the walls are not two loops of different lengths.
fn band_walls(w: &SurfaceWork, path: &[usize]) -> Vec<(u64, bool)> {
    let mut walls: Vec<(u32, u32)> = Vec::new();
    for &t in path {
        let tr = w.topo.tris[t];
        for k in 0..3 {
            if w.topo.nbr[3 * t + k] == NONE {
                walls.push((tr[k], tr[(k + 1) % 3]));
            }
        }
    }
    // the loops: nodes joined by wall segments (union-find over the band's wall nodes)
    let mut ids: Vec<u32> = walls.iter().flat_map(|&(a, b)| [a, b]).collect();
    ids.sort_unstable();
    ids.dedup();
    let index = |v: u32| ids.binary_search(&v).unwrap_or(0) as u32;
    let mut parent: Vec<u32> = (0..ids.len() as u32).collect();
    for &(a, b) in &walls {
        let (ra, rb) = (find(&mut parent, index(a)), find(&mut parent, index(b)));
        parent[ra as usize] = rb;
    }
    let loop_of: Vec<u32> = walls
        .iter()
        .map(|&(a, _)| find(&mut parent, index(a)))
        .collect();
    let mut loops: Vec<u32> = loop_of.clone();
    loops.sort_unstable();
    loops.dedup();
    if loops.len() != 2 {
        return Vec::new();
    }
    let count = |l: u32| loop_of.iter().filter(|&&x| x == l).count();
    let (c0, c1) = (count(loops[0]), count(loops[1]));
    if c0 == c1 {
        return Vec::new();
    }
    let long = if c0 > c1 { loops[0] } else { loops[1] };
    walls
        .iter()
        .zip(&loop_of)
        .map(|(&(a, b), &l)| (edge_key(a, b), l == long))
        .collect()
}

/// The surface work holding plan region `r` (numbered across surfaces from `offset`, the
/// first region of each surface), and the region's index within that surface.
fn region_of<'a>(work: &'a [SurfaceWork], offset: &[u32], r: u32) -> (&'a SurfaceWork, u32) {
    let wi = offset.partition_point(|&o| o <= r) - 1;
    (&work[wi], r - offset[wi])
}

/// True when group `g` is a plain segment group: no periodic images, no quad chord.
fn plain(list: &[Group], g: usize) -> bool {
    list[g].with.is_empty() && list[g].best.2 >= 0.0
}

/// Group and wanted flag of segment `key`, when it is a plain segment of the plan.
fn segment(segments: &[Segment], key: u64) -> Option<(usize, bool)> {
    segments
        .binary_search_by_key(&key, |s| s.key)
        .ok()
        .map(|p| (segments[p].group, segments[p].wanted))
}

/// The best column of region `local` of `w` whose first segment is in group `g1` and second
/// in `g2`, with its score (both wanted, then the shorter segment's length, longer first);
/// `None` when the region is not a strip or no pair of neighbours fits.
fn best_column(
    w: &SurfaceWork,
    local: u32,
    nodes: &NodeTable,
    segments: &[Segment],
    g1: usize,
    g2: usize,
) -> Option<(Column, (bool, f64))> {
    let topo = &w.topo;
    let walls_of = |t: usize| -> Vec<usize> {
        (0..3)
            .filter(|&k| topo.nbr[3 * t + k] == NONE)
            .collect::<Vec<_>>()
    };
    let in_region = |t: usize| w.region[t] == local;
    // a strip: every triangle of the region has a wall edge
    if (0..topo.len()).any(|t| in_region(t) && walls_of(t).is_empty()) {
        return None;
    }
    let xyz = |n: u32| nodes.coords[n as usize];
    let mut best: Option<(Column, (bool, f64))> = None;
    for t in (0..topo.len()).filter(|&t| in_region(t)) {
        let [k] = walls_of(t)[..] else { continue };
        let tri = topo.tris[t];
        let (x, y, z) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
        let Some((ga, wanted_a)) = segment(segments, edge_key(x, y)) else {
            continue;
        };
        if ga != g1 {
            continue;
        }
        // T's two interior edges, as (edge index, its nodes in T's order)
        for (j, p, q) in [((k + 1) % 3, y, z), ((k + 2) % 3, z, x)] {
            let u = topo.nbr[3 * t + j];
            if u == NONE {
                continue;
            }
            let u = u as usize;
            let [ku] = walls_of(u)[..] else { continue };
            let tu = topo.tris[u];
            let (s, e, apex) = (tu[ku], tu[(ku + 1) % 3], tu[(ku + 2) % 3]);
            // U's wall holds T's apex z, U's apex is on T's wall
            if !(s == z || e == z) || !(apex == x || apex == y) {
                continue;
            }
            let Some((gb, wanted_b)) = segment(segments, edge_key(s, e)) else {
                continue;
            };
            if gb != g2 {
                continue;
            }
            // after the splits at m (on x–y) and n (on s–e), the halves holding p→q and q→p
            // are (p, q, m) and (q, p, n); the flip makes (m, p, n) and (n, q, m)
            let m = 0.5 * (xyz(x) + xyz(y));
            let n = 0.5 * (xyz(s) + xyz(e));
            let normal = (xyz(y) - xyz(x)).cross(xyz(z) - xyz(x)).normalize_or_zero()
                + (xyz(e) - xyz(s))
                    .cross(xyz(apex) - xyz(s))
                    .normalize_or_zero();
            let turns = |a: DVec3, b: DVec3, c: DVec3| {
                (b - a).cross(c - a).normalize_or_zero().dot(normal) > 0.5
            };
            if !turns(m, xyz(p), n) || !turns(n, xyz(q), m) {
                continue;
            }
            let len_a = (xyz(x) - xyz(y)).length();
            let len_b = (xyz(s) - xyz(e)).length();
            let score = (wanted_a && wanted_b, len_a.min(len_b));
            if best.as_ref().is_none_or(|b| score > b.1) {
                best = Some((
                    Column {
                        surface: w.tag,
                        first: (x, y),
                        second: (s, e),
                        b: apex,
                        c: z,
                    },
                    score,
                ));
            }
        }
    }
    best
}

/// Flips, in the triangle blocks of `mesh`, the edge `b`–`c` of each column to join the
/// midpoints `m` and `n` of its two segments (node tags `(m, n, b, c)`): the triangles
/// `(p, q, m)` and `(q, p, n)` become `(m, p, n)` and `(n, q, m)`, orientation kept, tags
/// kept. A column whose two triangles are not found is left as split.
pub(super) fn flip_columns(mesh: &mut Mesh, flips: &[(u64, u64, u64, u64)]) {
    if flips.is_empty() {
        return;
    }
    // sorted (b, c, apex) keys of the wanted triangles, and where each was found
    let mut want: Vec<([u64; 3], usize)> = Vec::new();
    for (i, &(m, n, b, c)) in flips.iter().enumerate() {
        let (lo, hi) = (b.min(c), b.max(c));
        want.push(([lo, hi, m], 2 * i));
        want.push(([lo, hi, n], 2 * i + 1));
    }
    want.sort_unstable();
    let mut at: Vec<Option<(usize, usize)>> = vec![None; 2 * flips.len()];
    for (bi, blk) in mesh.element_blocks.iter().enumerate() {
        if blk.entity_dim != 2 || blk.element_type != etype::TRI3 {
            continue;
        }
        for i in 0..blk.len() {
            let e = blk.element(i);
            for r in 0..3 {
                let (lo, hi) = (e[r].min(e[(r + 1) % 3]), e[r].max(e[(r + 1) % 3]));
                let key = [lo, hi, e[(r + 2) % 3]];
                if let Ok(p) = want.binary_search_by_key(&key, |w| w.0) {
                    at[want[p].1] = Some((bi, i));
                }
            }
        }
    }
    for (i, &(m, n, _, _)) in flips.iter().enumerate() {
        let (Some((bx, ix)), Some((by, iy))) = (at[2 * i], at[2 * i + 1]) else {
            continue;
        };
        let rot = |bi: usize, ei: usize, last: u64, mesh: &Mesh| -> [u64; 3] {
            let e = mesh.element_blocks[bi].element(ei);
            let r = e.iter().position(|&v| v == last).unwrap_or(2);
            [e[(r + 1) % 3], e[(r + 2) % 3], e[r]]
        };
        let [p, q, _] = rot(bx, ix, m, mesh);
        let [q2, p2, _] = rot(by, iy, n, mesh);
        if (p, q) != (p2, q2) {
            continue;
        }
        mesh.element_blocks[bx].nodes[3 * ix..3 * ix + 3].copy_from_slice(&[m, p, n]);
        mesh.element_blocks[by].nodes[3 * iy..3 * iy + 3].copy_from_slice(&[n, q, m]);
    }
}
