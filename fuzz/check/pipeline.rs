//! The pipeline fuzz target's check, shared by `fuzz/fuzz_targets/pipeline.rs` and the
//! ordinary test suite (`tests/e2e/fuzz_seeds.rs` runs it over the seed corpus and the
//! recorded findings).
//!
//! The whole pipeline on arbitrary bytes: read → `quadrangulate` (default options: parity
//! repair, optimization, the validity gate, the fallback and the output numbered 1..N, with
//! the input → output tag map asked for). Whenever it returns Ok, the result, its tags
//! mapped back to the input's through the report's tag map, must pass the library's own
//! `recombine::check_invariants` against the mesh as read, and every quad must be valid:
//! four distinct nodes, no zero-length edge, and every corner strictly between 0° and 180°
//! measured in 3D about the area-weighted normal of the input faces at that corner's node,
//! or, for a node the input does not have, of the input faces nearest to a point inside the
//! corner, a quarter of the way along its two edges (which also means the quad is oriented
//! like them), or, at a wrapped node (a face there turns 90° or more from the node's
//! normal: a fold, a pin a few triangles round), on its own side: the mean unit normal of
//! the input faces there the quad holds (all their nodes among its own), else the input
//! faces nearest to that point inside the corner; and, where no node wraps and no input
//! face at its nodes turns 60° or more from the mean unit normal of the input faces it came
//! from (all their nodes among the quad's, else two, else one), about that mean, and
//! elsewhere its own normal turns less than 90° from the sum of the unit normals its
//! corners are measured about; and its scaled Jacobian at every corner about its own normal
//! (the cross product of its diagonals) is positive. That is the definition of
//! `blossomquad::validity`, written again here independently so that the gate itself is
//! checked. The output must also be numbered 1..N (nodes and elements) unless the
//! renumbering said why not. Anything else is a finding.
//!
//! With the environment variable `FUZZ_INVARIANTS_ONLY=1` only `check_invariants` is
//! asserted (to fuzz for invariant violations while quads with a flat corner, which a later
//! validity gate refuses, are still produced).

// `!(x > bound)` on purpose: a NaN measure is a finding, as in the gate
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::collections::HashMap;
use std::sync::OnceLock;

use blossomquad::mesh::{etype, Mesh};
use blossomquad::{msh, recombine};

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

/// Closest point to `p` on triangle `t` (regions of the triangle: inside, edges, corners).
fn closest_on_triangle(p: V, t: [V; 3]) -> V {
    let (a, b, c) = (t[0], t[1], t[2]);
    let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(p, a));
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = sub(p, b);
    let (d3, d4) = (dot(ab, bp), dot(ac, bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return add(a, ab.map(|x| x * v));
    }
    let cp = sub(p, c);
    let (d5, d6) = (dot(ab, cp), dot(ac, cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return add(a, ac.map(|x| x * w));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return add(b, sub(c, b).map(|x| x * w));
    }
    // inside: p moved onto the plane (not rebuilt from barycentric coordinates, whose
    // rounding a far corner of a sliver multiplies)
    let n = cross(ab, ac);
    let nn = dot(n, n);
    if !(nn > 0.0) {
        let denom = 1.0 / (va + vb + vc);
        let (v, w) = (vb * denom, vc * denom);
        return add(a, add(ab.map(|x| x * v), ac.map(|x| x * w)));
    }
    sub(p, n.map(|x| x * (dot(n, ap) / nn)))
}

/// One input face: its corners and twice its vector area (Newell).
struct Face {
    corners: Vec<V>,
    normal: V,
    nodes: Vec<u64>,
}

impl Face {
    fn distance(&self, p: V) -> f64 {
        let c = &self.corners;
        (1..c.len() - 1)
            .map(|k| norm(sub(p, closest_on_triangle(p, [c[0], c[k], c[k + 1]]))))
            .fold(f64::INFINITY, f64::min)
    }
}

/// The reference normal of a node the input surface does not have: the summed normals of
/// the input faces of the surface nearest to it (ties within `tie` all count).
fn nearest_normal(faces: &[Face], p: V, tie: f64) -> V {
    let d: Vec<f64> = faces.iter().map(|f| f.distance(p)).collect();
    let best = d.iter().copied().fold(f64::INFINITY, f64::min);
    let mut n = [0.0; 3];
    for (f, &df) in faces.iter().zip(&d) {
        if df <= best + tie {
            n = add(n, f.normal);
        }
    }
    n
}

/// Every quad of `after` valid against the faces of `before` (see the module doc).
pub fn check_quads(before: &Mesh, after: &Mesh) -> Result<(), String> {
    let cb = coords(before);
    let ca = coords(after);
    // per (surface, node): the area-weighted normal of the input faces at the node, and per
    // surface its faces
    let mut normal: HashMap<(i32, u64), V> = HashMap::new();
    let mut faces: HashMap<i32, Vec<Face>> = HashMap::new();
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    // ties: within 1e-9 of the input's extent, as in the gate
    for c in cb.values() {
        for d in 0..3 {
            lo[d] = lo[d].min(c[d]);
            hi[d] = hi[d].max(c[d]);
        }
    }
    let tie = 1e-9 * norm(sub(hi, lo)).max(f64::MIN_POSITIVE);
    for b in before.element_blocks.iter().filter(|b| {
        b.entity_dim == 2 && (b.element_type == etype::TRI3 || b.element_type == etype::QUAD4)
    }) {
        let k = b.nodes_per_element();
        for i in 0..b.len() {
            let t = b.element(i);
            let Some(c) = t
                .iter()
                .map(|v| cb.get(v).copied())
                .collect::<Option<Vec<V>>>()
            else {
                continue;
            };
            // twice the face's vector area: the sum at a node is the area-weighted normal,
            // the definition of `blossomquad::validity`
            let mut n = [0.0; 3];
            for j in 1..k - 1 {
                n = add(n, cross(sub(c[j], c[0]), sub(c[j + 1], c[0])));
            }
            if !n.iter().all(|x| x.is_finite()) {
                continue;
            }
            for &v in t {
                let e = normal.entry((b.entity_tag, v)).or_insert([0.0; 3]);
                *e = add(*e, n);
            }
            faces.entry(b.entity_tag).or_default().push(Face {
                corners: c,
                normal: n,
                nodes: t.to_vec(),
            });
        }
    }
    // the wrapped nodes: a face there turns WRAP_COS or more from the node's normal
    let mut wrapped: std::collections::HashSet<(i32, u64)> = Default::default();
    for (&s, list) in &faces {
        for f in list {
            let ln = norm(f.normal);
            for &v in &f.nodes {
                let m = normal[&(s, v)];
                if ln > 0.0
                    && norm(m) > 0.0
                    && dot(f.normal, m) <= blossomquad::validity::WRAP_COS * ln * norm(m)
                {
                    wrapped.insert((s, v));
                }
            }
        }
    }
    let no_faces: Vec<Face> = Vec::new();
    for b in after
        .element_blocks
        .iter()
        .filter(|b| b.entity_dim == 2 && b.element_type == etype::QUAD4)
    {
        let s = b.entity_tag;
        let surface_faces = faces.get(&s).unwrap_or(&no_faces);
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
            // the reference normal at each corner: the input's at its node, else (a node
            // the run added: parity and fallback splits, vertex duplications) the normal of
            // the input faces nearest to it
            let wraps = |k: usize| wrapped.contains(&(s, q[k]));
            let held_at = |k: usize| -> Option<V> {
                let held: Vec<&Face> = surface_faces
                    .iter()
                    .filter(|f| f.nodes.contains(&q[k]) && f.nodes.iter().all(|v| q.contains(v)))
                    .collect();
                (!held.is_empty()).then(|| {
                    let m = held.iter().fold([0.0; 3], |m, f| {
                        let l = norm(f.normal);
                        add(
                            m,
                            if l > 0.0 {
                                f.normal.map(|x| x / l)
                            } else {
                                [0.0; 3]
                            },
                        )
                    });
                    let l = norm(m);
                    if l > 0.0 {
                        m.map(|x| x / l)
                    } else {
                        [0.0; 3]
                    }
                })
            };
            // the input faces nearest to a point inside corner k, a quarter of the way along
            // its two edges (the faces the quad lies on there)
            let inside = |k: usize| {
                let a = sub(p[(k + 1) % 4], p[k]);
                let c = sub(p[(k + 3) % 4], p[k]);
                nearest_normal(surface_faces, add(p[k], add(a, c).map(|x| 0.25 * x)), tie)
            };
            let known: Vec<V> = (0..4)
                .map(|k| match normal.get(&(s, q[k])) {
                    // a wrapped node: the input faces there the quad holds (all their
                    // nodes among its own), else those nearest to a point inside the corner
                    Some(_) if wraps(k) => held_at(k).unwrap_or_else(|| inside(k)),
                    Some(n) if norm(*n) > 0.0 => *n,
                    // a node the run added, or whose faces cancel out
                    _ => inside(k),
                })
                .collect();
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
                let n = known[k];
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
                // the scaled Jacobian about the quad's own normal (its diagonals' cross
                // product) is positive
                let own = cross(sub(p[2], p[0]), sub(p[3], p[1]));
                let sj = dot(cross(a, c), own) / (norm(a) * norm(c) * norm(own));
                if !(sj > 1e-12) {
                    return Err(format!(
                        "surface {s}: quad {tag} {q:?} folds about its own normal at node {} (scaled Jacobian {sj:e})",
                        q[k]
                    ));
                }
                // corner strictly between 0 and 180 degrees about n: sin > tiny
                let s3 = dot(cross(a, c), n) / (norm(a) * norm(c) * ln);
                if !(s3 > 1e-12) {
                    return Err(format!(
                        "surface {s}: quad {tag} {q:?} has a corner at node {} that is not strictly between 0 and 180 degrees (sine {s3:e} about the input normal)",
                        q[k]
                    ));
                }
            }
            let unit = |v: V| {
                let l = norm(v);
                if l > 0.0 {
                    v.map(|x| x / l)
                } else {
                    [0.0; 3]
                }
            };
            // the mean unit normal of the input faces it came from (all their nodes among
            // the quad's, else two, else one), where one stands for it: no wrapped node and
            // no face at its nodes turning 60 degrees or more from it
            let came_from = || -> Option<V> {
                if (0..4).any(wraps) {
                    return None;
                }
                let shared: Vec<(&Face, usize)> = surface_faces
                    .iter()
                    .map(|f| (f, f.nodes.iter().filter(|v| q.contains(v)).count()))
                    .filter(|x| x.1 > 0)
                    .collect();
                let mean = [
                    |f: &Face, c: usize| c == f.nodes.len(),
                    |_: &Face, c: usize| c >= 2,
                    |_: &Face, c: usize| c >= 1,
                ]
                .iter()
                .map(|keep| {
                    shared
                        .iter()
                        .filter(|(f, c)| keep(f, *c))
                        .fold([0.0; 3], |m, (f, _)| add(m, unit(f.normal)))
                })
                .find(|m| norm(*m) > 0.0)
                .map(unit)?;
                let turns = shared.iter().any(|(f, _)| dot(unit(f.normal), mean) <= 0.5);
                (!turns).then_some(mean)
            };
            // every corner about that mean; elsewhere the quad faces the input's way: its
            // own normal turns less than 90 degrees from the sum of the unit normals its
            // corners are measured about
            let Some(mean) = came_from() else {
                let own = cross(sub(p[2], p[0]), sub(p[3], p[1]));
                let sum = known.iter().fold([0.0; 3], |m, n| add(m, unit(*n)));
                if !(dot(own, sum) > 0.0) {
                    return Err(format!(
                        "surface {s}: quad {tag} {q:?} faces away from the input surface (its own normal against the sum of its corners' input normals)"
                    ));
                }
                continue;
            };
            for k in 0..4 {
                let a = sub(p[(k + 1) % 4], p[k]);
                let c = sub(p[(k + 3) % 4], p[k]);
                let sm = dot(cross(a, c), mean) / (norm(a) * norm(c));
                if !(sm > 1e-12) {
                    return Err(format!(
                        "surface {s}: quad {tag} {q:?} has a corner at node {} that is reflex about the faces it came from (sine {sm:e})",
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

/// `(input tag, output tag)` pairs inverted: output tag → input tag.
fn inverse(pairs: &[(u64, u64)]) -> HashMap<u64, u64> {
    pairs.iter().map(|&(i, o)| (o, i)).collect()
}

/// An output tag as the input knew it: through `back` when the output renumbered them
/// (`changed`), else as it is; a tag the input did not have (a node or element the run
/// made) gets a fresh one above every tag of either numbering.
fn input_tag(t: u64, changed: bool, back: &HashMap<u64, u64>, fresh: &mut u64) -> u64 {
    if !changed {
        return t;
    }
    match back.get(&t) {
        Some(&i) => i,
        None => {
            *fresh += 1;
            *fresh
        }
    }
}

/// Checks that the output's node and element tags are 1..N without gaps.
fn check_numbering(after: &Mesh) -> Result<(), String> {
    let mut nodes: Vec<u64> = after
        .node_blocks
        .iter()
        .flat_map(|b| b.tags.iter().copied())
        .collect();
    nodes.sort_unstable();
    if nodes.iter().enumerate().any(|(i, &t)| t != i as u64 + 1) {
        return Err("the output's node tags are not 1..N".into());
    }
    let mut elements: Vec<u64> = after
        .element_blocks
        .iter()
        .flat_map(|b| b.tags.iter().copied())
        .collect();
    elements.sort_unstable();
    if elements.iter().enumerate().any(|(i, &t)| t != i as u64 + 1) {
        return Err("the output's element tags are not 1..N".into());
    }
    Ok(())
}

/// `after` with the input's tags back on every node and element the input had, through
/// the report's tag map (see [`input_tag`]).
fn with_input_tags(
    before: &Mesh,
    after: &Mesh,
    renumber: &blossomquad::renumber::RenumberReport,
) -> Result<Mesh, String> {
    let Some(map) = &renumber.map else {
        return Err("the tag map was asked for and not given".into());
    };
    let nodes_changed = renumber.nodes_changed > 0;
    let elements_changed = renumber.elements_changed > 0;
    let node_back = inverse(&map.nodes);
    let element_back = inverse(&map.elements);
    let top = before
        .max_node_tag()
        .max(before.max_element_tag())
        .max(after.max_node_tag())
        .max(after.max_element_tag());
    let mut fresh_node = top;
    let mut new_nodes: HashMap<u64, u64> = HashMap::new();
    let mut node = |t: u64| -> u64 {
        if !nodes_changed {
            return t;
        }
        match node_back.get(&t) {
            Some(&i) => i,
            None => *new_nodes.entry(t).or_insert_with(|| {
                fresh_node += 1;
                fresh_node
            }),
        }
    };
    let mut m = after.clone();
    for b in &mut m.node_blocks {
        for t in &mut b.tags {
            *t = node(*t);
        }
    }
    for b in &mut m.element_blocks {
        for t in &mut b.nodes {
            *t = node(*t);
        }
    }
    for p in &mut m.periodic {
        for (a, b) in &mut p.node_pairs {
            *a = node(*a);
            *b = node(*b);
        }
    }
    let mut fresh_element = top;
    for b in &mut m.element_blocks {
        for t in &mut b.tags {
            *t = input_tag(*t, elements_changed, &element_back, &mut fresh_element);
        }
    }
    Ok(m)
}

/// The check of one input (see the module doc): `Err` names the finding.
pub fn check(data: &[u8]) -> Result<(), String> {
    if data.len() > MAX_BYTES {
        return Ok(());
    }
    let Ok(mut mesh) = msh::read_bytes(data, "fuzz.msh") else {
        return Ok(());
    };
    if !small(&mesh) {
        return Ok(());
    }
    // the input the run works on: triangles repeating another's three nodes are removed
    // first, with a warning (a documented input repair)
    let before = match recombine::drop_repeated_triangles(&mesh) {
        Some((cleaned, _)) => cleaned,
        None => mesh.clone(),
    };
    // what the command line does (recombine, optimize, the validity gate, the fallback,
    // the numbering 1..N), with the tag map the comparison goes through
    let mut opts = blossomquad::Options::default();
    opts.tag_map = true;
    let Ok(report) = blossomquad::quadrangulate(&mut mesh, &opts) else {
        return Ok(());
    };
    // the renumbering's warnings are in the log; one of them says it kept the tags
    let renumbered = !report.log.iter().any(|l| l.contains("not numbered 1..N"));
    if renumbered {
        check_numbering(&mesh).map_err(|e| format!("exit 0 with {e}"))?;
    }
    let after = with_input_tags(&before, &mesh, &report.renumber)?;
    recombine::check_invariants(&before, &after)
        .map_err(|e| format!("exit 0 with a mesh that fails check_invariants: {e}"))?;
    if !invariants_only() {
        check_quads(&before, &after).map_err(|e| format!("exit 0 with an invalid quad: {e}"))?;
    }
    Ok(())
}
