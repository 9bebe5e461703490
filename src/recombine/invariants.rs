//! Invariants of recombination, checked from the two meshes alone. Deliberately simple
//! (sorted edge lists keyed by node tags, one surface at a time) and sharing no code with
//! the recombination itself. It runs on every `quadrangulate` call, so it is linear: its
//! sorts are radix sorts of packed tag pairs (`crate::keysort`), and it is parallel over
//! surfaces (and over its independent sorts within one).

use rayon::prelude::*;

use crate::keysort::sort_pairs;
use crate::mesh::{element_dim, etype, Mesh, NodeIndex};

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
    let mut all: Vec<Edge> = Vec::with_capacity(faces.len() * 4);
    for f in faces {
        for i in 0..f.len() {
            all.push(undirected(f[i], f[(i + 1) % f.len()]));
        }
    }
    sort_pairs(&mut all);
    let mut out: Vec<(Edge, u32)> = Vec::with_capacity(all.len() / 2 + 1);
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

/// Every directed edge of `faces`, sorted.
fn directed(faces: &[&[u64]]) -> Vec<Edge> {
    let mut s: Vec<Edge> = Vec::with_capacity(faces.len() * 4);
    for f in faces {
        for i in 0..f.len() {
            s.push((f[i], f[(i + 1) % f.len()]));
        }
    }
    sort_pairs(&mut s);
    s.dedup();
    s
}

/// Sorted directed edges with, when node tags are compact, the start of each node's run
/// (a lookup is then two nearby reads instead of a binary search over the whole list).
struct Directed {
    edges: Vec<Edge>,
    start: Vec<u32>,
}

impl Directed {
    fn new(edges: Vec<Edge>) -> Self {
        let max = edges.last().map_or(0, |e| e.0);
        let mut start = Vec::new();
        if max <= 8 * edges.len() as u64 + 1024 {
            start = vec![0u32; max as usize + 2];
            for e in &edges {
                start[e.0 as usize + 1] += 1;
            }
            for i in 1..start.len() {
                start[i] += start[i - 1];
            }
        }
        Directed { edges, start }
    }

    fn contains(&self, p: u64, q: u64) -> bool {
        if self.start.is_empty() {
            return has(&self.edges, &(p, q));
        }
        match (self.start.get(p as usize), self.start.get(p as usize + 1)) {
            (Some(&a), Some(&b)) => self.edges[a as usize..b as usize].iter().any(|e| e.1 == q),
            _ => false,
        }
    }
}

fn coord(mesh: &Mesh, index: &NodeIndex, t: u64) -> Option<[f64; 3]> {
    index
        .get(t)
        .map(|r| mesh.node_blocks[r.block as usize].coords[r.index as usize])
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
/// Returns the first violation found (the lowest surface tag first), in words, with the
/// surface and nodes involved.
pub fn check_invariants(before: &Mesh, after: &Mesh) -> Result<(), String> {
    if before.entities != after.entities {
        return Err("entities (or their physical groups) changed".into());
    }
    if before.physical_names != after.physical_names {
        return Err("physical names changed".into());
    }
    for b in &after.element_blocks {
        if b.element_type == etype::TRI3 && !b.is_empty() {
            return Err(format!(
                "surface {} still has {} triangles",
                b.entity_tag,
                b.len()
            ));
        }
    }
    let ib = before.node_index();
    let ia = after.node_index();
    let new_node = |t: u64| ib.get(t).is_none();
    // curve and point nodes unmoved
    for b in &before.node_blocks {
        if b.entity_dim > 1 {
            continue;
        }
        for (t, c) in b.tags.iter().zip(&b.coords) {
            match coord(after, &ia, *t) {
                Some(x) if x == *c => {}
                Some(x) => {
                    return Err(format!(
                        "node {t} on entity ({}, {}) moved from ({}, {}, {}) to ({}, {}, {})",
                        b.entity_dim, b.entity_tag, c[0], c[1], c[2], x[0], x[1], x[2]
                    ))
                }
                None => {
                    return Err(format!(
                        "node {t} on entity ({}, {}) disappeared",
                        b.entity_dim, b.entity_tag
                    ))
                }
            }
        }
    }
    // line elements: kept or split in two at a new node
    let lines = |m: &Mesh| -> Vec<Edge> {
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
    };
    let lb = lines(before);
    let la = lines(after);
    check_split_sets(&lb, &la, &new_node, "line elements")?;
    let mut surfaces: Vec<i32> = before
        .element_blocks
        .iter()
        .chain(&after.element_blocks)
        .filter(|b| b.entity_dim == 2 && element_dim(b.element_type) == Some(2))
        .map(|b| b.entity_tag)
        .collect();
    surfaces.sort_unstable();
    surfaces.dedup();
    let results: Vec<Result<(), String>> = surfaces
        .par_iter()
        .map(|&s| check_surface(before, after, &ib, &ia, &lb, s))
        .collect();
    results.into_iter().collect()
}

/// The per-surface part of [`check_invariants`].
fn check_surface(
    before: &Mesh,
    after: &Mesh,
    ib: &NodeIndex,
    ia: &NodeIndex,
    lb: &[Edge],
    s: i32,
) -> Result<(), String> {
    let new_node = |t: u64| ib.get(t).is_none();
    let fb = faces_of(before, s);
    let fa = faces_of(after, s);
    if let Some(f) = fa
        .iter()
        .find(|f| (1..f.len()).any(|j| f[..j].contains(&f[j])))
    {
        return Err(format!(
            "surface {s}: the face with nodes {} repeats a node",
            nodes_text(f)
        ));
    }
    // speed: the three sorted lists are independent (two cores: two at a time)
    let ((eb, ea), db) = rayon::join(
        || rayon::join(|| edge_counts(&fb), || edge_counts(&fa)),
        || Directed::new(directed(&fb)),
    );
    if let Some((e, c)) = ea.iter().find(|(e, c)| *c > 2 && count_of(&eb, e) <= 2) {
        return Err(format!(
            "surface {s}: the edge {}-{} is shared by {c} faces",
            e.0, e.1
        ));
    }
    let boundary = |counts: &[(Edge, u32)]| -> Vec<Edge> {
        counts
            .iter()
            .filter(|(_, c)| *c == 1)
            .map(|(e, _)| *e)
            .collect()
    };
    let bb = boundary(&eb);
    let ba = boundary(&ea);
    check_split_sets(&bb, &ba, &new_node, &format!("surface {s} boundary edges"))?;
    // curve segments of `before` that are no longer edges must be split in two at a new
    // node (found through the nodes next to each node along the edges of `after`, built
    // only when some segment is missing)
    let missing: Vec<&Edge> = lb
        .iter()
        .filter(|e| count_of(&eb, e) > 0 && count_of(&ea, e) == 0)
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
            return Err(format!(
                "surface {s}: the curve segment {}-{} is no longer an edge",
                e.0, e.1
            ));
        }
    }
    // orientation (faces in parallel; the first offending face in order is reported)
    let against = |f: &[u64]| -> Option<Edge> {
        (0..f.len())
            .map(|i| (f[i], f[(i + 1) % f.len()]))
            .find(|&(p, q)| db.contains(q, p) && !db.contains(p, q))
    };
    if let Some((f, (p, q))) = fa
        .par_iter()
        .with_min_len(CHUNK)
        .find_map_first(|f| against(f).map(|e| (f, e)))
    {
        return Err(format!(
            "surface {s}: the face with nodes {} runs edge {p}->{q} against the orientation of the input triangles",
            nodes_text(f)
        ));
    }
    // planar area (faces have 3 or 4 nodes: no allocation per face)
    let pts4 = |f: &[u64], m: &Mesh, idx: &NodeIndex| -> Option<([[f64; 3]; 4], usize)> {
        let mut p = [[0.0; 3]; 4];
        for (x, &t) in p.iter_mut().zip(f) {
            *x = coord(m, idx, t)?;
        }
        Some((p, f.len().min(4)))
    };
    // twice the summed vector area of `faces` projected on `n` (`None`: the vector itself),
    // by chunks of faces in parallel added in order (the same sum for any thread count);
    // the first face with an unknown node is an error
    let area = |faces: &[&[u64]], m: &Mesh, idx: &NodeIndex, what: &str| {
        let parts: Vec<Result<[f64; 3], String>> = faces
            .par_chunks(CHUNK)
            .map(|c| {
                let mut t = [0.0; 3];
                for f in c {
                    let p = pts4(f, m, idx).ok_or_else(|| {
                        format!(
                            "surface {s}: the {what} face with nodes {} has an unknown node",
                            nodes_text(f)
                        )
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
        Ok::<[f64; 3], String>(total)
    };
    let total = area(&fb, before, ib, "input")?;
    let norm = dot(total, total).sqrt();
    if norm == 0.0 {
        return Ok(());
    }
    let n = total.map(|x| x / norm);
    // planar: every corner of the input faces within 1e-10 of the extent (the largest
    // distance from the first corner) of the plane through the first corner
    let o = fb
        .first()
        .and_then(|f| f.first())
        .and_then(|&t| coord(before, ib, t))
        .unwrap_or([0.0; 3]);
    // (extent, largest distance from the plane, a distance that is not a number)
    let spread = |c: &[&[u64]]| {
        let mut r = (0.0_f64, 0.0_f64, false);
        for p in c
            .iter()
            .flat_map(|f| f.iter().filter_map(|&t| coord(before, ib, t)))
        {
            let d = sub(p, o);
            r.0 = r.0.max(dot(d, d).sqrt());
            let off = dot(d, n).abs();
            r.1 = r.1.max(off);
            r.2 |= off.is_nan();
        }
        r
    };
    let (extent, off, nan) = fb.par_chunks(CHUNK).map(spread).reduce(
        || (0.0, 0.0, false),
        |a, b| (a.0.max(b.0), a.1.max(b.1), a.2 || b.2),
    );
    let planar = !nan && off <= 1e-10 * extent.max(f64::MIN_POSITIVE);
    if !planar {
        return Ok(());
    }
    let area_after = dot(area(&fa, after, ia, "output")?, n);
    let area_before = dot(total, n);
    if ((area_after - area_before) / area_before).abs() > 1e-9 {
        return Err(format!(
            "surface {s}: planar area changed from {} to {}",
            area_before / 2.0,
            area_after / 2.0
        ));
    }
    Ok(())
}

/// `after` equals `before` where some edges `{a, b}` are replaced by `{a, m}`, `{m, b}` with
/// `m` a new node. Both lists sorted and deduplicated.
fn check_split_sets(
    before: &[Edge],
    after: &[Edge],
    new_node: &dyn Fn(u64) -> bool,
    what: &str,
) -> Result<(), String> {
    // the halves, as (new node, far end), sorted: pairs of them rebuild a split edge
    let mut halves: Vec<(u64, u64)> = Vec::new();
    for &(x, y) in after.iter().filter(|e| !has(before, e)) {
        match (new_node(x), new_node(y)) {
            (true, false) => halves.push((x, y)),
            (false, true) => halves.push((y, x)),
            _ => return Err(format!("{what}: the edge {x}-{y} is new")),
        }
    }
    halves.sort_unstable();
    let mut rebuilt: Vec<Edge> = Vec::with_capacity(halves.len() / 2);
    let mut i = 0;
    while i < halves.len() {
        let m = halves[i].0;
        let j = halves[i..].partition_point(|h| h.0 == m) + i;
        if j - i != 2 {
            return Err(format!(
                "{what}: new node {m} is on {} of them, not 2",
                j - i
            ));
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
            None => return Err(format!("{what}: the edge {}-{} disappeared", e.0, e.1)),
        }
    }
    if let Some(k) = used.iter().position(|u| !u) {
        let e = rebuilt[k];
        return Err(format!(
            "{what}: the split edge {}-{} was not one of them",
            e.0, e.1
        ));
    }
    Ok(())
}
