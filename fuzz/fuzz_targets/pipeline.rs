//! The whole pipeline on arbitrary bytes: read → `quadrangulate` (default options: parity
//! repair, optimization, the validity gate and the fallback). Whenever it returns Ok, the
//! result must pass the library's own
//! `recombine::check_invariants` against the mesh as read, and every quad must be valid:
//! four distinct nodes, no zero-length edge, and every corner strictly between 0° and 180°
//! measured in 3D about the area-weighted normal of the input triangles at that corner
//! (which also means the quad is oriented like them). That is the definition of
//! `blossomquad::validity`, written again here independently so that the gate itself is
//! checked. Anything else is a finding (a panic).
//!
//! With the environment variable `FUZZ_INVARIANTS_ONLY=1` only `check_invariants` is
//! asserted (to fuzz for invariant violations while quads with a flat corner, which a later
//! validity gate refuses, are still produced).
#![no_main]

use std::collections::HashMap;
use std::sync::OnceLock;

use blossomquad::mesh::{etype, Mesh};
use blossomquad::{msh, recombine};
use libfuzzer_sys::fuzz_target;

const MAX_BYTES: usize = 64 * 1024;
const MAX_NODES: usize = 400;
const MAX_ELEMENTS: usize = 400;

fn invariants_only() -> bool {
    static FLAG: OnceLock<bool> = OnceLock::new();
    *FLAG.get_or_init(|| std::env::var_os("FUZZ_INVARIANTS_ONLY").is_some_and(|v| v != "0"))
}

type V = [f64; 3];

fn sub(a: V, b: V) -> V {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn add(a: V, b: V) -> V {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
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
fn norm(a: V) -> f64 {
    dot(a, a).sqrt()
}

fn coords(mesh: &Mesh) -> HashMap<u64, V> {
    let mut m = HashMap::new();
    for b in &mesh.node_blocks {
        for (t, c) in b.tags.iter().zip(&b.coords) {
            m.insert(*t, *c);
        }
    }
    m
}

/// Every quad of `after` valid against the triangles of `before` (see the module doc).
fn check_quads(before: &Mesh, after: &Mesh) -> Result<(), String> {
    let cb = coords(before);
    let ca = coords(after);
    // per (surface, node): the area-weighted normal of the input triangles at the node
    let mut normal: HashMap<(i32, u64), V> = HashMap::new();
    for b in before
        .element_blocks
        .iter()
        .filter(|b| b.entity_dim == 2 && b.element_type == etype::TRI3)
    {
        for i in 0..b.len() {
            let t = b.element(i);
            let (Some(&p0), Some(&p1), Some(&p2)) = (cb.get(&t[0]), cb.get(&t[1]), cb.get(&t[2]))
            else {
                continue;
            };
            // twice the triangle's vector area: the sum at a node is the area-weighted
            // normal, the definition of `blossomquad::validity`
            let n = cross(sub(p1, p0), sub(p2, p0));
            if !n.iter().all(|x| x.is_finite()) {
                continue;
            }
            for &v in &t[..3] {
                let e = normal.entry((b.entity_tag, v)).or_insert([0.0; 3]);
                *e = add(*e, n);
            }
        }
    }
    for b in after
        .element_blocks
        .iter()
        .filter(|b| b.entity_dim == 2 && b.element_type == etype::QUAD4)
    {
        let s = b.entity_tag;
        for i in 0..b.len() {
            let q = &b.element(i)[..4];
            let tag = b.tags[i];
            let mut sorted = q.to_vec();
            sorted.sort_unstable();
            sorted.dedup();
            if sorted.len() != 4 {
                return Err(format!("surface {s}: quad {tag} {q:?} repeats a node"));
            }
            let mut p = [[0.0; 3]; 4];
            for k in 0..4 {
                p[k] = *ca.get(&q[k]).ok_or_else(|| {
                    format!("surface {s}: quad {tag} names missing node {}", q[k])
                })?;
            }
            // the quad's own reference normal: the input normals at its nodes (a node added
            // by parity repair has none; its quad's other nodes give it)
            // (unit normals; a node whose faces cancel out has none)
            let known: Vec<Option<V>> = q
                .iter()
                .map(|&v| {
                    let n = normal.get(&(s, v)).copied()?;
                    let l = norm(n);
                    (l > 0.0 && l.is_finite()).then(|| n.map(|x| x / l))
                })
                .collect();
            let mut mean = [0.0; 3];
            for n in known.iter().flatten() {
                mean = add(mean, *n);
            }
            if norm(mean) == 0.0 {
                // no node of the quad is an input node of the surface (the fallback's centre
                // and edge nodes): the surface's summed input normal
                for ((ts, _), n) in &normal {
                    if *ts == s {
                        mean = add(mean, *n);
                    }
                }
            }
            for k in 0..4 {
                let e = sub(p[(k + 1) % 4], p[k]);
                if norm(e) == 0.0 {
                    return Err(format!(
                        "surface {s}: quad {tag} {q:?} has a zero-length edge {}-{}",
                        q[k],
                        q[(k + 1) % 4]
                    ));
                }
            }
            for k in 0..4 {
                let n = known[k].unwrap_or(mean);
                let ln = norm(n);
                if !(ln > 0.0) {
                    // quads of a surface whose input triangles all have zero area: no
                    // reference normal exists, so none of its corners can be valid
                    return Err(format!(
                        "surface {s}: quad {tag} {q:?} comes from degenerate triangles (no normal at node {})",
                        q[k]
                    ));
                }
                let a = sub(p[(k + 1) % 4], p[k]);
                let c = sub(p[(k + 3) % 4], p[k]);
                // corner strictly between 0 and 180 degrees about n: sin > tiny
                let s3 = dot(cross(a, c), n) / (norm(a) * norm(c) * ln);
                if !(s3 > 1e-12) {
                    return Err(format!(
                        "surface {s}: quad {tag} {q:?} has a corner at node {} that is not strictly between 0 and 180 degrees (sine {s3:e} about the input normal)",
                        q[k]
                    ));
                }
            }
        }
    }
    Ok(())
}

fn small(mesh: &Mesh) -> bool {
    mesh.node_count() <= MAX_NODES && mesh.element_count() <= MAX_ELEMENTS
}

fuzz_target!(|data: &[u8]| {
    if data.len() > MAX_BYTES {
        return;
    }
    let Ok(mut mesh) = msh::read_bytes(data, "fuzz.msh") else {
        return;
    };
    if !small(&mesh) {
        return;
    }
    let before = mesh.clone();
    // what the command line does: recombine, optimize, the validity gate and the fallback
    if blossomquad::quadrangulate(&mut mesh, &blossomquad::Options::default()).is_err() {
        return;
    }
    if let Err(e) = recombine::check_invariants(&before, &mesh) {
        panic!("exit 0 with a mesh that fails check_invariants: {e}");
    }
    if !invariants_only() {
        if let Err(e) = check_quads(&before, &mesh) {
            panic!("exit 0 with an invalid quad: {e}");
        }
    }
});
