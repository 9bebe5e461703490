//! From a perfect matching to quads: plain merges, and the post-processing of extra edges
//! by edge swap (section 5.3.1) and vertex duplication (section 5.3.2). Design in the
//! module documentation of [`super`].

use glam::DVec3;

use super::fan::{fan_frame, place_duplicate, worst_margin, Fan, FanFrame};
use super::geometry::{has_hopeless_corner, merged_quad, tri_normal};
use super::graph::Graph;
use super::topology::{SurfaceTopo, NONE};

/// A node created by vertex duplication.
#[derive(Debug, Clone)]
pub(crate) struct NewNode {
    /// Position.
    pub pos: DVec3,
    /// Global ids of the fan's inner vertices `a_1 … a_{k−1}` (used to average parametric
    /// coordinates).
    pub near: Vec<u32>,
}

/// Quads of one surface.
#[derive(Debug, Default)]
pub(crate) struct Faces {
    /// Quads as node ids: global ids, or `n_global + j` for `new_nodes[j]`.
    pub quads: Vec<[u32; 4]>,
    /// For each quad, the triangle whose element tag it reuses.
    pub source: Vec<u32>,
    /// Nodes created by vertex duplication.
    pub new_nodes: Vec<NewNode>,
    /// Extra edges in the matching.
    pub extra_used: usize,
    /// Edge swaps done.
    pub swaps: usize,
    /// Vertex duplications done.
    pub duplications: usize,
}

impl Faces {
    /// These quads with every node id `v` in them (quad corners and new nodes' neighbours)
    /// replaced by `f(v)`; `None` when `f` gives none for one of them.
    pub(super) fn with_ids(&self, f: impl Fn(u32) -> Option<u32>) -> Option<Faces> {
        let quads = self
            .quads
            .iter()
            .map(|q| {
                let mut out = *q;
                for v in &mut out {
                    *v = f(*v)?;
                }
                Some(out)
            })
            .collect::<Option<Vec<_>>>()?;
        let new_nodes = self
            .new_nodes
            .iter()
            .map(|n| {
                Some(NewNode {
                    pos: n.pos,
                    near: n.near.iter().map(|&v| f(v)).collect::<Option<Vec<_>>>()?,
                })
            })
            .collect::<Option<Vec<_>>>()?;
        Some(Faces {
            quads,
            source: self.source.clone(),
            new_nodes,
            extra_used: self.extra_used,
            swaps: self.swaps,
            duplications: self.duplications,
        })
    }
}

/// Merges two oriented polygons sharing an edge run in opposite directions. `None` when they
/// share no such edge.
pub(super) fn merge<T: Copy + PartialEq>(a: &[T], b: &[T]) -> Option<Vec<T>> {
    let (na, nb) = (a.len(), b.len());
    for i in 0..na {
        let (p, q) = (a[i], a[(i + 1) % na]);
        for j in 0..nb {
            if b[j] == q && b[(j + 1) % nb] == p {
                let mut out = Vec::with_capacity(na + nb - 2);
                out.extend_from_slice(&a[..=i]);
                for s in 2..nb {
                    out.push(b[(j + s) % nb]);
                }
                out.extend_from_slice(&a[i + 1..]);
                return Some(out);
            }
        }
    }
    None
}

/// Builds the quads from the matching `mate` (a perfect matching of `graph`).
pub(crate) fn build_faces(
    topo: &SurfaceTopo,
    graph: &Graph,
    mate: &[u32],
    coords: &[DVec3],
    n_global: u32,
) -> Result<Faces, String> {
    let n = topo.len();
    let mut faces: Vec<Vec<u32>> = Vec::with_capacity(n / 2 + 8);
    let mut source: Vec<u32> = Vec::with_capacity(n / 2 + 8);
    let mut alive: Vec<bool> = Vec::with_capacity(n / 2 + 8);
    let mut tri_face = vec![NONE; n];
    for t in 0..n {
        if tri_face[t] != NONE {
            continue;
        }
        let m = mate[t];
        if m as usize >= n {
            return Err(format!("triangle {t} is unmatched"));
        }
        if let Some(k) = (0..3).find(|&k| topo.nbr[3 * t + k] == m) {
            tri_face[t] = faces.len() as u32;
            tri_face[m as usize] = faces.len() as u32;
            faces.push(merged_quad(topo, t, k).to_vec());
            source.push(t as u32);
            alive.push(true);
        }
    }
    // the used extra edges: their two triangles stay separate faces for now
    let mut used: Vec<usize> = Vec::new();
    for (i, fan) in graph.extra_fans.iter().enumerate() {
        let (a, b) = (fan.tris[0], fan.tris[fan.tris.len() - 1]);
        if mate[a as usize] == b && tri_face[a as usize] == NONE {
            used.push(i);
            for t in [a, b] {
                tri_face[t as usize] = faces.len() as u32;
                faces.push(topo.tris[t as usize].to_vec());
                source.push(t);
                alive.push(true);
            }
        }
    }
    if let Some(t) = tri_face.iter().position(|&f| f == NONE) {
        return Err(format!(
            "triangle {t} is matched to {} through no graph edge",
            mate[t]
        ));
    }
    let mut out = Faces {
        extra_used: used.len(),
        ..Faces::default()
    };
    // how many used fans each triangle belongs to: a swap must touch nothing else
    let mut mark = vec![0u8; n];
    for &i in &used {
        for &t in &graph.extra_fans[i].tris {
            mark[t as usize] = mark[t as usize].saturating_add(1);
        }
    }
    let mut joined = Joined::around(topo, used.iter().map(|&i| graph.extra_fans[i].v));
    for &i in &used {
        let fan = &graph.extra_fans[i];
        if try_swap(
            topo,
            fan,
            mate,
            &mark,
            coords,
            &mut faces,
            &mut alive,
            &tri_face,
            &mut joined,
        ) {
            out.swaps += 1;
        } else {
            duplicate(topo, fan, coords, n_global, &mut faces, &tri_face, &mut out)?;
            out.duplications += 1;
        }
    }
    for (f, poly) in faces.iter().enumerate() {
        if !alive[f] {
            continue;
        }
        let [a, b, c, d] = poly[..] else {
            return Err(format!(
                "post-processing left a face with {} nodes (from triangle {})",
                poly.len(),
                source[f]
            ));
        };
        out.quads.push([a, b, c, d]);
        out.source.push(source[f]);
    }
    Ok(out)
}

/// The nodes an edge joins to the apexes of the used extra edges' fans: the surface's
/// triangle edges at those apexes, and the diagonals earlier swaps drew from them. A swap
/// may not draw a diagonal between two nodes an edge already joins: where a surface wraps
/// round so tightly that the hexagon's far vertex is also a neighbour of the apex (a pin
/// meshed coarser than its radius), the new quads would share that edge with the faces
/// already on it.
struct Joined {
    /// (apex, node) pairs, sorted.
    pairs: Vec<(u32, u32)>,
    /// Diagonals drawn by swaps, as (smaller, larger) node ids.
    drawn: Vec<(u32, u32)>,
}

impl Joined {
    /// The edges at `apexes` in the triangles of `topo` (one pass over the triangles).
    fn around(topo: &SurfaceTopo, apexes: impl Iterator<Item = u32>) -> Self {
        let mut apexes: Vec<u32> = apexes.collect();
        apexes.sort_unstable();
        apexes.dedup();
        let mut pairs = Vec::new();
        if !apexes.is_empty() {
            for t in &topo.tris {
                for (k, &v) in t.iter().enumerate() {
                    if apexes.binary_search(&v).is_ok() {
                        pairs.push((v, t[(k + 1) % 3]));
                        pairs.push((v, t[(k + 2) % 3]));
                    }
                }
            }
        }
        pairs.sort_unstable();
        pairs.dedup();
        Joined {
            pairs,
            drawn: Vec::new(),
        }
    }

    /// Whether an edge already joins apex `v` and node `x`.
    fn joins(&self, v: u32, x: u32) -> bool {
        self.pairs.binary_search(&(v, x)).is_ok() || self.drawn.contains(&(v.min(x), v.max(x)))
    }
}

/// Edge swap (5.3.1): fan `t1 t2 t3` at `v` with `t1–t3` matched by the extra edge and `t2`
/// matched to `t4` across the edge opposite `v`. The hexagon `t1 ∪ t2 ∪ t4 ∪ t3` is cut by
/// the diagonal from `v` to `t4`'s far vertex `x` into two quads (the diagonal `a1 a2` of the
/// quad `t2 ∪ t4` is swapped to `v x`). Applied only when none of the four triangles takes
/// part in another used extra edge's fan and the new diagonal lies inside the quad
/// `t2 ∪ t4` (so both new quads are simple polygons, possibly non-convex, never folded)
/// and no corner of the new quads is nearly straight or zero (corner η ≤
/// [`FIXED_CORNER_MIN_ETA`](super::geometry::FIXED_CORNER_MIN_ETA)) and no edge joins `v`
/// and `x` already ([`Joined`]); returns false (nothing changed, the fan then gets a vertex
/// duplication) otherwise.
#[allow(clippy::too_many_arguments)]
fn try_swap(
    topo: &SurfaceTopo,
    fan: &Fan,
    mate: &[u32],
    mark: &[u8],
    coords: &[DVec3],
    faces: &mut [Vec<u32>],
    alive: &mut [bool],
    tri_face: &[u32],
    joined: &mut Joined,
) -> bool {
    if fan.tris.len() != 3 || fan.tris.iter().any(|&t| mark[t as usize] != 1) {
        return false;
    }
    let (t1, t2, t3) = (fan.tris[0], fan.tris[1], fan.tris[2]);
    let t4 = mate[t2 as usize];
    if mark[t4 as usize] != 0 || topo.tris[t4 as usize].contains(&fan.v) {
        return false;
    }
    let v = fan.v;
    let Some(x) = topo.tris[t4 as usize]
        .iter()
        .copied()
        .find(|x| !topo.tris[t2 as usize].contains(x))
    else {
        return false;
    };
    let tri = |t: u32| topo.tris[t as usize].to_vec();
    let hex = merge(&tri(t1), &tri(t2))
        .and_then(|p| merge(&p, &tri(t4)))
        .and_then(|p| merge(&p, &tri(t3)));
    let Some(h) = hex else { return false };
    if h.len() != 6 {
        return false;
    }
    let Some(iv) = h.iter().position(|&p| p == v) else {
        return false;
    };
    if h[(iv + 3) % 6] != x || joined.joins(v, x) {
        return false;
    }
    let at = |s: usize| h[(iv + s) % 6];
    // the diagonal v-x must lie inside the quad (v, h2, x, h4): both halves turn like the
    // input triangles
    let p = |i: u32| coords[i as usize];
    let normal: DVec3 = [t1, t2, t3, t4]
        .iter()
        .map(|&t| tri_normal(coords, topo.tris[t as usize]))
        .sum();
    let turn = |a: u32, b: u32, c: u32| (p(b) - p(a)).cross(p(c) - p(a)).dot(normal);
    if turn(v, at(2), x) <= 0.0 || turn(v, x, at(4)) <= 0.0 {
        return false;
    }
    // a (nearly) straight or zero corner in a new quad would stay for good when its node is
    // on a wall (e.g. two successive segments of a straight curve): leave those fans to the
    // vertex duplication, which keeps every boundary corner of the input
    let hopeless = |q: [u32; 4]| has_hopeless_corner(&q.map(p), normal, |_| true);
    if hopeless([at(0), at(1), at(2), at(3)]) || hopeless([at(3), at(4), at(5), at(0)]) {
        return false;
    }
    faces[tri_face[t1 as usize] as usize] = vec![at(0), at(1), at(2), at(3)];
    faces[tri_face[t3 as usize] as usize] = vec![at(3), at(4), at(5), at(0)];
    alive[tri_face[t2 as usize] as usize] = false;
    joined.drawn.push((v.min(x), v.max(x)));
    true
}

/// Vertex duplication (5.3.2): fan `t1 … tk` at `v` with `t1–tk` matched by the extra edge.
/// A new node `v'` is put inside the fan; every face holding a middle triangle `t2 … t(k−1)`
/// gets `v'` instead of `v`, and `v'` is inserted into the edges `{v, a1}` of `t1` and
/// `{v, a(k−1)}` of `tk`, which become the quads `(v, v', a1, u)` and `(v, a(k−1), v', w)`
/// (in the orientation of the triangles). The new edge `v v'` is shared by these two quads.
fn duplicate(
    topo: &SurfaceTopo,
    fan: &Fan,
    coords: &[DVec3],
    n_global: u32,
    faces: &mut [Vec<u32>],
    tri_face: &[u32],
    out: &mut Faces,
) -> Result<(), String> {
    let v = fan.v;
    let k = fan.tris.len();
    let vp = n_global + out.new_nodes.len() as u32;
    let Some(FanFrame { near, mean, normal }) = fan_frame(topo, coords, fan) else {
        return Err(format!("fan at node id {v} is not connected"));
    };
    // 1. middle faces: v -> v'
    for &t in &fan.tris[1..k - 1] {
        let f = tri_face[t as usize] as usize;
        for p in faces[f].iter_mut() {
            if *p == v {
                *p = vp;
            }
        }
    }
    // 2. end faces: insert v' on the edge towards the fan
    let ends = [
        (fan.tris[0], fan.tris[1], near[0]),
        (fan.tris[k - 1], fan.tris[k - 2], near[k - 2]),
    ];
    for (end, inner, a) in ends {
        let fe = tri_face[end as usize] as usize;
        let fi = tri_face[inner as usize] as usize;
        let poly = &faces[fe];
        let m = poly.len();
        let Some(iv) = poly.iter().position(|&p| p == v) else {
            return Err(format!(
                "vertex duplication: node id {v} missing from its fan"
            ));
        };
        let (prev, next) = (poly[(iv + m - 1) % m], poly[(iv + 1) % m]);
        // the neighbour of v shared with the inner face, where v' now sits
        let inner_poly = &faces[fi];
        let insert_after = if next == a {
            iv
        } else if prev == a {
            (iv + m - 1) % m
        } else if inner_poly.contains(&next) && inner_poly.contains(&vp) {
            iv
        } else if inner_poly.contains(&prev) && inner_poly.contains(&vp) {
            (iv + m - 1) % m
        } else {
            return Err(format!(
                "vertex duplication at node id {v}: end triangle does not border the fan"
            ));
        };
        faces[fe].insert(insert_after + 1, vp);
    }
    let earlier = &out.new_nodes;
    let at = |i: u32, cand: DVec3| match i.checked_sub(n_global) {
        _ if i == vp => cand,
        None => coords[i as usize],
        Some(k) => earlier.get(k as usize).map_or(cand, |nn| nn.pos),
    };
    let touched = fan
        .tris
        .iter()
        .map(|&t| &faces[tri_face[t as usize] as usize][..]);
    let (pos, _) = place_duplicate(coords[v as usize], mean, |cand| {
        worst_margin(touched.clone(), |i| at(i, cand), normal)
    });
    out.new_nodes.push(NewNode { pos, near });
    Ok(())
}
