//! Topology that MSH 2.x does not store, derived from the elements: entity bounding boxes
//! and bounding entities (points of curves, curves of surfaces, surfaces of volumes).
//!
//! An entity `B` of dimension `d - 1` bounds entity `E` of dimension `d` when some facet of
//! `B`'s elements (a point, an edge, a triangle or quad face, compared by corner nodes) is
//! a facet used exactly once by `E`'s elements. Facets used twice (embedded curves inside a
//! surface) do not make a bounding entity. Signs are positive except for a curve's end
//! point, which is negative as Gmsh writes it.

use std::collections::{HashMap, HashSet};

use super::tags::TagSet;
use crate::mesh::{element_dim, Entity, Mesh};

/// Corner count of an element type's family (first nodes are the corners in Gmsh's
/// ordering), `None` for families whose facets we do not derive.
fn corners(element_type: u32) -> Option<usize> {
    match element_type {
        15 => Some(1),
        1 | 8 | 26 | 27 | 28 | 62..=66 => Some(2),
        2 | 9 | 20..=25 | 42..=46 | 52..=56 => Some(3),
        3 | 10 | 16 | 36..=41 | 47..=51 | 57..=61 => Some(4),
        4 | 11 | 29..=33 | 71..=75 | 79..=83 | 137 => Some(4),
        5 | 12 | 17 | 92..=105 => Some(8),
        _ => None,
    }
}

/// Facet key: sorted corner tags padded with `u64::MAX`.
type Key = [u64; 4];

fn key(nodes: &[u64]) -> Key {
    let mut k = [u64::MAX; 4];
    for (s, &v) in k.iter_mut().zip(nodes) {
        *s = v;
    }
    k[..nodes.len().min(4)].sort_unstable();
    k
}

/// Calls `f` with each facet (as corner node tags) of an element of type `ty`.
fn facets(ty: u32, nodes: &[u64], mut f: impl FnMut(&[u64])) {
    let dim = element_dim(ty).unwrap_or(0);
    let Some(c) = corners(ty) else { return };
    if nodes.len() < c {
        return;
    }
    match (dim, c) {
        (1, 2) => {
            f(&nodes[0..1]);
            f(&nodes[1..2]);
        }
        (2, n) => {
            for i in 0..n {
                f(&[nodes[i], nodes[(i + 1) % n]]);
            }
        }
        (3, 4) => {
            for t in [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]] {
                f(&[nodes[t[0]], nodes[t[1]], nodes[t[2]]]);
            }
        }
        (3, 8) => {
            for q in [
                [0, 1, 2, 3],
                [4, 5, 6, 7],
                [0, 1, 5, 4],
                [1, 2, 6, 5],
                [2, 3, 7, 6],
                [3, 0, 4, 7],
            ] {
                f(&[nodes[q[0]], nodes[q[1]], nodes[q[2]], nodes[q[3]]]);
            }
        }
        _ => {}
    }
}

/// Adds a bare entity (no physical group, box from its nodes) for every node or element block
/// whose entity `$Entities` does not define (legal: Gmsh reads 4.1 files without
/// `$Entities`). Returns how many were added.
pub(crate) fn missing_entities(mesh: &mut Mesh) -> usize {
    let missing = find_missing_entities(mesh);
    for &(d, t) in &missing {
        mesh.entities[d as usize].push(Entity {
            dim: d,
            tag: t,
            bbox: [0.0; 6],
            physical_tags: Vec::new(),
            bounding: Vec::new(),
        });
    }
    let added: HashSet<(i32, i32)> = missing.iter().copied().collect();
    if !added.is_empty() {
        boxes(mesh, &added);
    }
    added.len()
}

/// The (dim, tag) of entities that blocks use but `mesh.entities` lacks, in first-use order.
pub(crate) fn find_missing_entities(mesh: &Mesh) -> Vec<(i32, i32)> {
    let mut have: HashSet<(i32, i32)> = mesh
        .entities
        .iter()
        .flatten()
        .map(|e| (e.dim, e.tag))
        .collect();
    let pairs: Vec<(i32, i32)> = mesh
        .node_blocks
        .iter()
        .map(|b| (b.entity_dim, b.entity_tag))
        .chain(
            mesh.element_blocks
                .iter()
                .map(|b| (b.entity_dim, b.entity_tag)),
        )
        .collect();
    let mut missing = Vec::new();
    for (d, t) in pairs {
        if (0..4).contains(&d) && have.insert((d, t)) {
            missing.push((d, t));
        }
    }
    missing
}

/// An empty bounding box (`[min xyz, max xyz]`), neutral for [`grow_box`].
pub(crate) const EMPTY_BOX: [f64; 6] = [
    f64::INFINITY,
    f64::INFINITY,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::NEG_INFINITY,
    f64::NEG_INFINITY,
];

/// Extends box `b` to contain point `c`.
#[inline]
pub(crate) fn grow_box(b: &mut [f64; 6], c: &[f64; 3]) {
    for k in 0..3 {
        b[k] = b[k].min(c[k]);
        b[k + 3] = b[k + 3].max(c[k]);
    }
}

/// The box to store: all zeros when nothing was added.
pub(crate) fn finish_box(b: [f64; 6]) -> [f64; 6] {
    if b[0] <= b[3] {
        b
    } else {
        [0.0; 6]
    }
}

/// Sets the bounding box of the entities in `only` from the nodes classified on them and
/// the nodes of their elements.
fn boxes(mesh: &mut Mesh, only: &HashSet<(i32, i32)>) {
    let wanted = |d: i32, t: i32| only.contains(&(d, t));
    let index = mesh.node_index();
    let mut acc: HashMap<(i32, i32), [f64; 6]> = HashMap::new();
    let empty = EMPTY_BOX;
    for nb in mesh
        .node_blocks
        .iter()
        .filter(|b| wanted(b.entity_dim, b.entity_tag))
    {
        let b = acc.entry((nb.entity_dim, nb.entity_tag)).or_insert(empty);
        for c in &nb.coords {
            grow_box(b, c);
        }
    }
    for eb in mesh
        .element_blocks
        .iter()
        .filter(|b| wanted(b.entity_dim, b.entity_tag))
    {
        let b = acc.entry((eb.entity_dim, eb.entity_tag)).or_insert(empty);
        for &v in &eb.nodes {
            if let Some(r) = index.get(v) {
                if let Some(c) = mesh
                    .node_blocks
                    .get(r.block as usize)
                    .and_then(|nb| nb.coords.get(r.index as usize))
                {
                    grow_box(b, c);
                }
            }
        }
    }
    for ents in mesh.entities.iter_mut() {
        for e in ents.iter_mut().filter(|e| wanted(e.dim, e.tag)) {
            e.bbox = finish_box(acc.get(&(e.dim, e.tag)).copied().unwrap_or(EMPTY_BOX));
        }
    }
}

/// Derives `Entity::bounding` for curves, surfaces and volumes (see the module doc).
pub(crate) fn bounding_entities(mesh: &mut Mesh) {
    for dim in 1..=3i32 {
        if !mesh.element_blocks.iter().any(|b| b.entity_dim == dim) {
            continue;
        }
        // Facets of the lower-dimension entities' elements → those entities.
        let mut low: HashMap<Key, Vec<i32>> = HashMap::new();
        for eb in mesh
            .element_blocks
            .iter()
            .filter(|b| b.entity_dim == dim - 1)
        {
            let Some(c) = corners(eb.element_type) else {
                continue;
            };
            let k = eb.nodes_per_element();
            if k == 0 || c > 4 {
                continue;
            }
            for el in eb.nodes.chunks_exact(k) {
                let v = low.entry(key(&el[..c])).or_default();
                if !v.contains(&eb.entity_tag) {
                    v.push(eb.entity_tag);
                }
            }
        }
        if low.is_empty() {
            continue;
        }
        // Nodes of those facets: most facets of the higher-dimension elements touch none of
        // them and are rejected by one bit test instead of a hash lookup.
        let (low_nodes, _) = TagSet::new(
            mesh.element_blocks
                .iter()
                .filter(|b| b.entity_dim == dim - 1)
                .map(|b| b.nodes.as_slice()),
        );
        // For each entity of `dim`, count uses of those facets, and remember start corners
        // (for curves: the first node of an element is a start).
        let mut uses: HashMap<(i32, Key), (u32, bool)> = HashMap::new();
        for eb in mesh.element_blocks.iter().filter(|b| b.entity_dim == dim) {
            let k = eb.nodes_per_element();
            if k == 0 {
                continue;
            }
            let ty = eb.element_type;
            for el in eb.nodes.chunks_exact(k) {
                let first = el[0];
                facets(ty, el, |f| {
                    if !f.iter().all(|&v| low_nodes.contains(v)) {
                        return;
                    }
                    let kk = key(f);
                    if low.contains_key(&kk) {
                        let u = uses.entry((eb.entity_tag, kk)).or_insert((0, false));
                        u.0 += 1;
                        if f.len() == 1 && f[0] == first {
                            u.1 = true;
                        }
                    }
                });
            }
        }
        let mut bound: HashMap<i32, Vec<i32>> = HashMap::new();
        let mut pairs: Vec<_> = uses.into_iter().collect();
        pairs.sort_unstable_by_key(|((t, k), _)| (*t, *k));
        for ((tag, kk), (n, start)) in pairs {
            if n != 1 {
                continue;
            }
            for &b in low.get(&kk).into_iter().flatten() {
                let signed = if dim == 1 && !start { -b } else { b };
                let v = bound.entry(tag).or_default();
                if !v.contains(&signed) && !v.contains(&-signed) {
                    v.push(signed);
                }
            }
        }
        if let Some(ents) = mesh.entities.get_mut(dim as usize) {
            for e in ents.iter_mut() {
                if let Some(v) = bound.remove(&e.tag) {
                    e.bounding = v;
                }
            }
        }
    }
}
