//! Periodic curves and surfaces seen by the parity repair (a split mirrored on the image),
//! and the chords of quads a split runs along.

use super::*;

/// Sorted `(from, to)` node pairs (global ids).
pub(super) type NodeMap = Vec<(u32, u32)>;

/// The `$Periodic` links between curves, as node maps both ways (global ids).
pub(crate) struct PeriodicCurves {
    /// Per link: (slave curve, master curve, slave → master, master → slave).
    links: Vec<(i32, i32, NodeMap, NodeMap)>,
    /// Every curve in some link, sorted.
    curves: Vec<i32>,
}

/// The `$Periodic` links of dimension `dim` as (slave, master, slave → master, master →
/// slave) node maps, and every entity in some link, sorted.
pub(super) type PeriodicLinks = Vec<(i32, i32, NodeMap, NodeMap)>;

pub(super) fn periodic_links(
    mesh: &Mesh,
    nodes: &NodeTable,
    dim: i32,
) -> (PeriodicLinks, Vec<i32>) {
    let mut links = Vec::new();
    let mut tags = Vec::new();
    for l in mesh.periodic.iter().filter(|l| l.dim == dim) {
        let mut fwd: Vec<(u32, u32)> = l
            .node_pairs
            .iter()
            .filter_map(|&(s, m)| Some((nodes.id(s)?, nodes.id(m)?)))
            .collect();
        let mut back: Vec<(u32, u32)> = fwd.iter().map(|&(s, m)| (m, s)).collect();
        fwd.sort_unstable();
        back.sort_unstable();
        links.push((l.tag, l.master_tag, fwd, back));
        tags.extend([l.tag, l.master_tag]);
    }
    tags.sort_unstable();
    tags.dedup();
    (links, tags)
}

impl PeriodicCurves {
    pub(super) fn new(mesh: &Mesh, nodes: &NodeTable) -> Self {
        let (links, curves) = periodic_links(mesh, nodes, 1);
        PeriodicCurves { links, curves }
    }

    pub(super) fn has(&self, c: i32) -> bool {
        self.curves.binary_search(&c).is_ok()
    }

    /// The images of segment `a`–`b` of curve `c` on every curve linked to it (directly or
    /// through a chain of links), as `(curve, a', b')`; `None` when some link lacks the
    /// correspondence of an end node (the split could not be mirrored).
    pub(super) fn images(&self, c: i32, a: u32, b: u32) -> Option<Vec<(i32, u32, u32)>> {
        let look =
            |m: &[(u32, u32)], x: u32| m.binary_search_by_key(&x, |p| p.0).ok().map(|i| m[i].1);
        let mut seen = vec![(c, a, b)];
        let mut head = 0;
        while head < seen.len() {
            let (cc, x, y) = seen[head];
            head += 1;
            for (s, m, fwd, back) in &self.links {
                let (to, map) = if *s == cc {
                    (*m, fwd)
                } else if *m == cc {
                    (*s, back)
                } else {
                    continue;
                };
                if seen.iter().any(|q| q.0 == to) {
                    continue;
                }
                seen.push((to, look(map, x)?, look(map, y)?));
            }
        }
        Some(seen.split_off(1))
    }
}

/// The `$Periodic` links between surfaces, with the edges of their slave and master
/// surfaces: a segment on the boundary of one of them is split together with its images
/// (used when the segment's curve is not known, so the curve links cannot be).
pub(crate) struct PeriodicSurfaces {
    /// Per link: (slave, master, slave → master, master → slave).
    links: Vec<(i32, i32, NodeMap, NodeMap)>,
    /// (edge key, surface) of every element edge of a surface in some link, sorted.
    edges: Vec<(u64, i32)>,
}

impl PeriodicSurfaces {
    pub(super) fn new(mesh: &Mesh, nodes: &NodeTable) -> Self {
        let (links, surfaces) = periodic_links(mesh, nodes, 2);
        let mut edges = Vec::new();
        if !links.is_empty() {
            for b in &mesh.element_blocks {
                if b.entity_dim != 2
                    || (b.element_type != etype::TRI3 && b.element_type != etype::QUAD4)
                    || surfaces.binary_search(&b.entity_tag).is_err()
                {
                    continue;
                }
                for i in 0..b.len() {
                    let e = b.element(i);
                    for j in 0..e.len() {
                        if let (Some(x), Some(y)) = (nodes.id(e[j]), nodes.id(e[(j + 1) % e.len()]))
                        {
                            edges.push((edge_key(x, y), b.entity_tag));
                        }
                    }
                }
            }
            edges.sort_unstable();
            edges.dedup();
        }
        PeriodicSurfaces { links, edges }
    }

    pub(super) fn is_empty(&self) -> bool {
        self.links.is_empty()
    }

    pub(super) fn on(&self, key: u64, surface: i32) -> bool {
        self.edges.binary_search(&(key, surface)).is_ok()
    }

    /// The images of segment `a`–`b` through the surface links (directly or through a
    /// chain of them): for each link whose slave (master) has the segment as an element
    /// edge, its image on the master (slave), which must be an element edge there. `None`
    /// when some link lacks the correspondence of an end node or the image is not an edge
    /// (the split could not be mirrored); empty when the segment is on no periodic surface.
    pub(super) fn images(&self, a: u32, b: u32) -> Option<Vec<(u32, u32)>> {
        let look =
            |m: &[(u32, u32)], x: u32| m.binary_search_by_key(&x, |p| p.0).ok().map(|i| m[i].1);
        let mut seen = vec![(a.min(b), a.max(b))];
        let mut head = 0;
        while head < seen.len() {
            let (x, y) = seen[head];
            head += 1;
            let k = edge_key(x, y);
            for (s, m, fwd, back) in &self.links {
                for (from, to, map) in [(*s, *m, fwd), (*m, *s, back)] {
                    if !self.on(k, from) {
                        continue;
                    }
                    let (x2, y2) = (look(map, x)?, look(map, y)?);
                    if !self.on(edge_key(x2, y2), to) {
                        return None;
                    }
                    let e = (x2.min(y2), x2.max(y2));
                    if !seen.contains(&e) {
                        seen.push(e);
                    }
                }
            }
        }
        Some(seen.split_off(1))
    }
}

/// For every wall segment bordered by quads (`blocked`), the quad chord through it: the
/// edges reached by repeatedly stepping from an edge to the opposite edge of each quad
/// holding it. Splitting all of them at their midpoints splits each quad of the chord into
/// two quads and keeps the mesh conforming; the triangles on the chord's end edges are split
/// like any parity split. Chords where a quad would be crossed both ways, that touch a
/// periodic curve, or that are longer than 10⁵ edges are left out. Each chord is returned
/// once, as `(a, b, curve)` edges starting with its wall segment.
pub(super) fn quad_chords(
    mesh: &Mesh,
    nodes: &NodeTable,
    walls: &[(u64, u32, bool)],
    blocked: &[u64],
    wall_curve: &dyn Fn(u64) -> Option<i32>,
    curve_of: &dyn Fn(u64) -> Option<i32>,
    periodic: &PeriodicCurves,
) -> Vec<Vec<(u32, u32, Option<i32>)>> {
    // (edge key, quad index, position of the edge in the quad)
    let mut quads: Vec<[u32; 4]> = Vec::new();
    for b in &mesh.element_blocks {
        if b.entity_dim != 2 || b.element_type != etype::QUAD4 {
            continue;
        }
        for i in 0..b.len() {
            let e = b.element(i);
            let ids: Vec<u32> = e.iter().filter_map(|&t| nodes.id(t)).collect();
            if let [p, q, r, s] = ids[..] {
                quads.push([p, q, r, s]);
            }
        }
    }
    let mut by_edge: Vec<(u64, u32, u8)> = Vec::with_capacity(4 * quads.len());
    for (qi, q) in quads.iter().enumerate() {
        for j in 0..4 {
            by_edge.push((edge_key(q[j], q[(j + 1) % 4]), qi as u32, j as u8));
        }
    }
    by_edge.sort_unstable();
    let mut starts: Vec<u64> = walls
        .iter()
        .map(|w| w.0)
        .filter(|k| blocked.binary_search(k).is_ok())
        .collect();
    starts.dedup();
    let mut done: std::collections::HashSet<u64> = std::collections::HashSet::new();
    let mut out = Vec::new();
    let mut dir: HashMap<u32, u8> = HashMap::new();
    let mut in_chord: std::collections::HashSet<u64> = std::collections::HashSet::new();
    'chord: for &start in &starts {
        if done.contains(&start) {
            continue;
        }
        dir.clear();
        in_chord.clear();
        in_chord.insert(start);
        let mut edges = vec![start];
        let mut head = 0;
        while head < edges.len() {
            let key = edges[head];
            head += 1;
            let lo = by_edge.partition_point(|x| x.0 < key);
            for &(_, qi, j) in by_edge[lo..].iter().take_while(|x| x.0 == key) {
                let axis = j % 2;
                match dir.get(&qi) {
                    Some(&d) if d == axis => continue,
                    Some(_) => continue 'chord,
                    None => {}
                }
                dir.insert(qi, axis);
                let q = quads[qi as usize];
                let o = (j as usize + 2) % 4;
                let opp = edge_key(q[o], q[(o + 1) % 4]);
                if in_chord.insert(opp) {
                    edges.push(opp);
                }
                if edges.len() > 100_000 {
                    continue 'chord;
                }
            }
        }
        let mut chord = Vec::with_capacity(edges.len());
        for &k in &edges {
            let is_wall = walls.binary_search_by_key(&k, |w| w.0).is_ok();
            let c = if is_wall { wall_curve(k) } else { curve_of(k) };
            if c.is_some_and(|c| periodic.has(c)) {
                continue 'chord;
            }
            chord.push(((k >> 32) as u32, k as u32, c));
        }
        done.extend(edges.iter().copied());
        out.push(chord);
    }
    out
}
