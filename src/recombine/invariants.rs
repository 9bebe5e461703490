//! Invariants of recombination, checked from the two meshes alone. Deliberately simple
//! (hash maps keyed by node tags) and sharing no code with the recombination itself.

use std::collections::{HashMap, HashSet};

use crate::mesh::{element_dim, etype, Mesh};

type Edge = (u64, u64);

fn undirected(a: u64, b: u64) -> Edge {
    (a.min(b), a.max(b))
}

/// Corner nodes of a 2D element of a supported type (tri3, quad4).
fn faces_of(mesh: &Mesh, surface: i32) -> Vec<Vec<u64>> {
    let mut out = Vec::new();
    for b in &mesh.element_blocks {
        if b.entity_dim != 2 || b.entity_tag != surface || element_dim(b.element_type) != Some(2) {
            continue;
        }
        let k = match b.element_type {
            etype::TRI3 => 3,
            etype::QUAD4 => 4,
            _ => continue,
        };
        for i in 0..b.len() {
            out.push(b.element(i)[..k].to_vec());
        }
    }
    out
}

fn edge_counts(faces: &[Vec<u64>]) -> HashMap<Edge, usize> {
    let mut m = HashMap::new();
    for f in faces {
        for i in 0..f.len() {
            *m.entry(undirected(f[i], f[(i + 1) % f.len()])).or_insert(0) += 1;
        }
    }
    m
}

fn directed(faces: &[Vec<u64>]) -> HashSet<Edge> {
    let mut s = HashSet::new();
    for f in faces {
        for i in 0..f.len() {
            s.insert((f[i], f[(i + 1) % f.len()]));
        }
    }
    s
}

fn coords(mesh: &Mesh) -> HashMap<u64, [f64; 3]> {
    let mut m = HashMap::new();
    for b in &mesh.node_blocks {
        for (t, c) in b.tags.iter().zip(&b.coords) {
            m.insert(*t, *c);
        }
    }
    m
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
/// Returns the first violation found, with the surface and nodes involved.
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
    let cb = coords(before);
    let ca = coords(after);
    let new_node = |t: u64| !cb.contains_key(&t);
    // curve and point nodes unmoved
    for b in &before.node_blocks {
        if b.entity_dim > 1 {
            continue;
        }
        for (t, c) in b.tags.iter().zip(&b.coords) {
            match ca.get(t) {
                Some(x) if x == c => {}
                Some(x) => {
                    return Err(format!(
                        "node {t} on entity ({}, {}) moved from {} to {}",
                        b.entity_dim,
                        b.entity_tag,
                        point(c),
                        point(x)
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
    let lines = |m: &Mesh| -> HashSet<Edge> {
        let mut s = HashSet::new();
        for b in &m.element_blocks {
            if b.element_type == etype::LINE2 {
                for i in 0..b.len() {
                    let e = b.element(i);
                    s.insert(undirected(e[0], e[1]));
                }
            }
        }
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
    for s in surfaces {
        let fb = faces_of(before, s);
        let fa = faces_of(after, s);
        for f in &fa {
            let mut sorted = f.clone();
            sorted.sort_unstable();
            sorted.dedup();
            if sorted.len() != f.len() {
                return Err(format!(
                    "surface {s}: face with nodes {} repeats a node",
                    nodes(f)
                ));
            }
        }
        let eb = edge_counts(&fb);
        let ea = edge_counts(&fa);
        if let Some((e, c)) = ea
            .iter()
            .find(|(e, &c)| c > 2 && eb.get(e).copied().unwrap_or(0) <= 2)
        {
            return Err(format!(
                "surface {s}: edge {} is shared by {c} faces",
                edge(e)
            ));
        }
        let bb: HashSet<Edge> = eb
            .iter()
            .filter(|(_, &c)| c == 1)
            .map(|(e, _)| *e)
            .collect();
        let ba: HashSet<Edge> = ea
            .iter()
            .filter(|(_, &c)| c == 1)
            .map(|(e, _)| *e)
            .collect();
        check_split_sets(&bb, &ba, &new_node, &format!("surface {s} boundary edges"))?;
        for e in lb.iter().filter(|e| eb.contains_key(e)) {
            if !ea.contains_key(e) && !split_present(e, &ea, &new_node) {
                return Err(format!(
                    "surface {s}: curve segment {} is no longer an edge",
                    edge(e)
                ));
            }
        }
        // orientation
        let db = directed(&fb);
        for f in &fa {
            for i in 0..f.len() {
                let (p, q) = (f[i], f[(i + 1) % f.len()]);
                if db.contains(&(q, p)) && !db.contains(&(p, q)) {
                    return Err(format!(
                        "surface {s}: face with nodes {} runs edge {p}-{q} against the orientation of the input triangles",
                        nodes(f)
                    ));
                }
            }
        }
        // planar area
        let pts = |f: &Vec<u64>, m: &HashMap<u64, [f64; 3]>| -> Option<Vec<[f64; 3]>> {
            f.iter().map(|t| m.get(t).copied()).collect()
        };
        let mut total = [0.0; 3];
        let mut polys_b = Vec::new();
        for f in &fb {
            let p = pts(f, &cb).ok_or_else(|| {
                format!(
                    "surface {s}: input face with nodes {} has an unknown node",
                    nodes(f)
                )
            })?;
            let a = vector_area(&p);
            for k in 0..3 {
                total[k] += a[k];
            }
            polys_b.push(p);
        }
        let norm = dot(total, total).sqrt();
        if norm == 0.0 {
            continue;
        }
        let n = total.map(|x| x / norm);
        let o = polys_b
            .first()
            .and_then(|p| p.first())
            .copied()
            .unwrap_or([0.0; 3]);
        let extent = polys_b
            .iter()
            .flatten()
            .map(|p| dot(sub(*p, o), sub(*p, o)).sqrt())
            .fold(0.0, f64::max);
        let planar = polys_b
            .iter()
            .flatten()
            .all(|p| dot(sub(*p, o), n).abs() <= 1e-10 * extent.max(f64::MIN_POSITIVE));
        if !planar {
            continue;
        }
        let mut area_after = 0.0;
        for f in &fa {
            let p = pts(f, &ca).ok_or_else(|| {
                format!(
                    "surface {s}: output face with nodes {} has an unknown node",
                    nodes(f)
                )
            })?;
            area_after += dot(vector_area(&p), n);
        }
        let area_before = dot(total, n);
        if ((area_after - area_before) / area_before).abs() > 1e-9 {
            return Err(format!(
                "surface {s}: planar area changed from {} to {}",
                area_before / 2.0,
                area_after / 2.0
            ));
        }
    }
    Ok(())
}

/// `{a, m}` and `{m, b}` both in `set` for some new node `m`.
fn split_present(e: &Edge, set: &HashMap<Edge, usize>, new_node: &dyn Fn(u64) -> bool) -> bool {
    set.keys().any(|&(x, y)| {
        let m = if x == e.0 || x == e.1 {
            y
        } else if y == e.0 || y == e.1 {
            x
        } else {
            return false;
        };
        let other = if x == m { y } else { x };
        let far = if other == e.0 { e.1 } else { e.0 };
        new_node(m) && set.contains_key(&undirected(m, far))
    })
}

/// `after` equals `before` where some edges `{a, b}` are replaced by `{a, m}`, `{m, b}` with
/// `m` a new node.
fn check_split_sets(
    before: &HashSet<Edge>,
    after: &HashSet<Edge>,
    new_node: &dyn Fn(u64) -> bool,
    what: &str,
) -> Result<(), String> {
    // pair up the halves through their new node
    let mut halves: HashMap<u64, Vec<u64>> = HashMap::new();
    for &(x, y) in after.difference(before) {
        match (new_node(x), new_node(y)) {
            (true, false) => halves.entry(x).or_default().push(y),
            (false, true) => halves.entry(y).or_default().push(x),
            _ => return Err(format!("{what}: edge {x}-{y} is new")),
        }
    }
    let mut rebuilt: HashSet<Edge> = HashSet::new();
    for (m, ends) in &halves {
        if ends.len() != 2 {
            return Err(format!(
                "{what}: new node {m} is on {} of them, not 2",
                ends.len()
            ));
        }
        rebuilt.insert(undirected(ends[0], ends[1]));
    }
    for e in before.difference(after) {
        if !rebuilt.remove(e) {
            return Err(format!("{what}: edge {} disappeared", edge(e)));
        }
    }
    if let Some(e) = rebuilt.iter().next() {
        return Err(format!(
            "{what}: split edge {} was not one of them",
            edge(e)
        ));
    }
    Ok(())
}

/// "nodes 1 2 3" for messages.
fn nodes(f: &[u64]) -> String {
    f.iter()
        .map(|t| t.to_string())
        .collect::<Vec<_>>()
        .join(" ")
}

/// "3-4" for messages.
fn edge(e: &(u64, u64)) -> String {
    format!("{}-{}", e.0, e.1)
}

/// "(x, y, z)" for messages.
fn point(p: &[f64; 3]) -> String {
    format!("({}, {}, {})", p[0], p[1], p[2])
}
