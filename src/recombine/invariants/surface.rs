//! The checks of one surface against its state before: boundary, conformity, area,
//! orientation, and the sets of split edges.

use super::*;

impl SurfaceBefore {
    pub(super) fn new(before: &Mesh, ib: &TagCoords, s: i32) -> Self {
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

/// New nodes along one curve segment of `before` that the checks follow at most (each a
/// split of a split's half).
const MAX_CHAIN: usize = 8;

/// The edges of `counts` used by one face.
pub(super) fn boundary(counts: &[(Edge, u32)]) -> Vec<Edge> {
    counts
        .iter()
        .filter(|(_, c)| *c == 1)
        .map(|(e, _)| *e)
        .collect()
}

/// The per-surface part of [`check_invariants`].
pub(super) fn check_surface(
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
        let next_to = |v: u64| {
            let from = nbr.partition_point(|x| x.0 < v);
            nbr[from..].iter().take_while(move |x| x.0 == v).map(|x| x.1)
        };
        // a new node on the segment `e` (within a millionth of its length of the chord)
        let on_segment = |m: u64, e: &Edge| -> bool {
            let (Some(p), Some(q), Some(x)) = (ib.get(e.0), ib.get(e.1), ia.get(m)) else {
                return false;
            };
            let (p, q, x) = (
                glam::DVec3::from_array(p),
                glam::DVec3::from_array(q),
                glam::DVec3::from_array(x),
            );
            let d = q - p;
            let t = (x - p).dot(d) / d.length_squared().max(f64::MIN_POSITIVE);
            (0.0..=1.0).contains(&t) && (p + t * d).distance(x) <= 1e-6 * d.length()
        };
        // split in two at a new node, or into more along the segment (a split of a split's
        // half)
        let split_present = |e: &Edge| -> bool {
            if next_to(e.0).any(|m| new_node(m) && count_of(&ea, &undirected(m, e.1)) > 0) {
                return true;
            }
            let mut frontier = vec![e.0];
            let mut seen: Vec<u64> = Vec::new();
            for _ in 0..MAX_CHAIN {
                let mut next = Vec::new();
                for v in frontier {
                    for m in next_to(v) {
                        if m == e.1 && v != e.0 {
                            return true;
                        }
                        if new_node(m) && !seen.contains(&m) && on_segment(m, e) {
                            seen.push(m);
                            next.push(m);
                        }
                    }
                }
                frontier = next;
            }
            false
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

/// `after` equals `before` where some edges `{a, b}` are replaced by a chain `{a, m₁}`,
/// `{m₁, m₂}`, …, `{mₖ, b}` through new nodes (one split, or a split of a split's half:
/// a fallback's split of a line, then a parity split of one of its halves). Both lists
/// sorted and deduplicated.
pub(super) fn check_split_sets(
    before: &[Edge],
    after: &[Edge],
    new_node: &dyn Fn(u64) -> bool,
    set: EdgeSet,
) -> Result<(), InvariantViolation> {
    // the new edges at each new node, as (new node, other end), sorted, and the chains'
    // ends, as (old node, new node)
    let mut halves: Vec<(u64, u64)> = Vec::new();
    let mut ends: Vec<(u64, u64)> = Vec::new();
    for &(x, y) in after.iter().filter(|e| !has(before, e)) {
        let (nx, ny) = (new_node(x), new_node(y));
        if !nx && !ny {
            return Err(InvariantViolation::NewEdge { set, edge: (x, y) });
        }
        for (p, q, new) in [(x, y, nx), (y, x, ny)] {
            if new {
                halves.push((p, q));
            } else {
                ends.push((p, q));
            }
        }
    }
    halves.sort_unstable();
    ends.sort_unstable();
    // every new node is inside a chain: two new edges
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
        i = j;
    }
    let beside = |m: u64, from: u64| -> u64 {
        let k = halves.partition_point(|h| h.0 < m);
        if halves[k].1 == from {
            halves[k + 1].1
        } else {
            halves[k].1
        }
    };
    // each chain from its smaller old end to the other; the new nodes it passes
    let mut rebuilt: Vec<Edge> = Vec::with_capacity(ends.len() / 2);
    let mut passed = 0;
    for &(a, first) in &ends {
        let (mut prev, mut m, mut count) = (a, first, 1);
        let b = loop {
            let next = beside(m, prev);
            if !new_node(next) {
                break next;
            }
            (prev, m, count) = (m, next, count + 1);
            if count > halves.len() {
                break a;
            }
        };
        if a < b {
            rebuilt.push(undirected(a, b));
            passed += count;
        }
    }
    // new nodes no chain reached (a cycle of new nodes), or a chain back to its start
    if 2 * passed != halves.len() {
        let reached = |m: u64| ends.iter().any(|e| e.1 == m);
        let m = halves.iter().map(|h| h.0).find(|&m| !reached(m)).unwrap_or(halves[0].0);
        return Err(InvariantViolation::SplitNode {
            set,
            node: m,
            halves: 2,
        });
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
