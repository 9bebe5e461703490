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
pub(super) fn check_split_sets(
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
