//! The input's curved geometry: points of line3 and tri6 elements, each surface's map from
//! the flat corner triangles onto its curved triangles and the projection onto it, the
//! curves' line3 chains, and the serendipity centre of a quad.

use super::*;

/// Point of the 3-node line `(a, b, m)` (ends at ξ = -1 and 1, `m` at 0) at `xi`.
pub fn line3_point(a: DVec3, b: DVec3, m: DVec3, xi: f64) -> DVec3 {
    a * (0.5 * xi * (xi - 1.0)) + b * (0.5 * xi * (xi + 1.0)) + m * (1.0 - xi * xi)
}

/// Point of the 6-node triangle `x` (Gmsh order: corners, then mid-edge nodes of edges
/// 0-1, 1-2, 2-0) at barycentric coordinates `l` (weights of corners 0, 1, 2).
pub fn tri6_point(x: &[DVec3; 6], l: [f64; 3]) -> DVec3 {
    let [a, b, c] = l;
    x[0] * (a * (2.0 * a - 1.0))
        + x[1] * (b * (2.0 * b - 1.0))
        + x[2] * (c * (2.0 * c - 1.0))
        + x[3] * (4.0 * a * b)
        + x[4] * (4.0 * b * c)
        + x[5] * (4.0 * c * a)
}

/// One surface of the input: its flat corner triangles (to locate points) and their six
/// nodes (to map them onto the curved surface).
pub(super) struct SurfaceGeometry {
    pub(super) locator: TriSurface,
    pub(super) six: Vec<[DVec3; 6]>,
    /// A triangle at each input corner node: where searches near that node start.
    pub(super) node_tri: FastMap<u64, u32>,
}

impl SurfaceGeometry {
    /// The point of the curved surface nearest `q` (to first order): the flat point `p`
    /// whose image `Φ(p)` differs from `q` only along the normal, found by fixed-point
    /// steps from the flat point closest to `q` (`Φ` is the identity plus a small
    /// distortion, so a few steps converge). Returns `q` itself when `q` is already on the
    /// curved surface to rounding (a planar surface's points do not move).
    /// `near`: input corner nodes close to `q`, whose triangles the search starts from (a
    /// walk across a few triangles instead of a search of the whole surface).
    pub(super) fn project(&self, q: DVec3, near: &[u64]) -> Option<DVec3> {
        let start = near.iter().find_map(|t| self.node_tri.get(t));
        let mut hit = match start {
            Some(&t) => self.locator.walk(t, q)?,
            None => self.locator.closest(q)?,
        };
        let mut best: Option<(f64, DVec3, f64)> = None;
        for _ in 0..8 {
            let x = self.six.get(hit.tri as usize)?;
            let size = (x[1] - x[0]).length() + (x[2] - x[1]).length() + (x[0] - x[2]).length();
            let y = tri6_point(x, hit.bary);
            let r = q - y;
            let n = self.locator.normal(hit.tri);
            let rt = r - n * r.dot(n);
            let err = rt.length();
            // converged, or no longer converging (rounding level): the best point so far
            let stalled = best.is_some_and(|(e, _, _)| err > 0.5 * e);
            if best.is_none_or(|(e, _, _)| err < e) {
                best = Some((err, y, size));
            }
            if err <= 1e-13 * size || stalled {
                break;
            }
            hit = self.locator.walk(hit.tri, hit.point + rt)?;
        }
        let (_, y, size) = best?;
        if y.distance(q) <= 1e-12 * size {
            return Some(q);
        }
        Some(y)
    }
}

/// The input's curved geometry.
pub(super) struct Geometry<'a> {
    pub(super) input: &'a Mesh,
    /// Every input node (coordinates by tag).
    pub(super) nodes: NodeTable,
    /// Input edge (sorted corner tags) -> its mid-edge node.
    pub(super) mid: FastMap<(u64, u64), u64>,
    /// Input 9-node quad (sorted corner tags) -> its face node.
    pub(super) face: FastMap<[u64; 4], u64>,
    pub(super) surfaces: FastMap<i32, SurfaceGeometry>,
    /// Input line3 elements per curve: `[a, b, m]`.
    pub(super) curves: FastMap<i32, Vec<[u64; 3]>>,
}

impl<'a> Geometry<'a> {
    /// Coordinates of input node `t`.
    pub(super) fn at(&self, t: u64) -> Option<DVec3> {
        self.nodes.at(t)
    }

    /// Entity (dim, tag) of input node `t`, and its parametric coordinates if any.
    pub(super) fn owner(&self, t: u64) -> Option<(i32, i32, Option<Vec<f64>>)> {
        let r = self.nodes.node_ref(t)?;
        let b = self.input.node_blocks.get(r.block as usize)?;
        let np = b.entity_dim.max(0) as usize;
        let i = r.index as usize;
        let params = b
            .params
            .as_ref()
            .and_then(|p| p.get(i * np..(i + 1) * np))
            .map(|p| p.to_vec());
        Some((b.entity_dim, b.entity_tag, params))
    }

    pub(super) fn new(input: &'a Mesh) -> Geometry<'a> {
        let nodes = NodeTable::new(input);
        let coords = &nodes;
        let mut mid = FastMap::default();
        let mut face = FastMap::default();
        let mut curves: FastMap<i32, Vec<[u64; 3]>> = FastMap::default();
        // per surface: curved triangles as corner tags and mid-edge points (edges 0-1,
        // 1-2, 2-0; `None`: the straight midpoint)
        type Piece = ([u64; 3], [Option<DVec3>; 3]);
        let mut tris: FastMap<i32, Vec<Piece>> = FastMap::default();
        let at = |t: u64| coords.at(t);
        for b in &input.element_blocks {
            match (b.entity_dim, b.element_type) {
                (2, etype::TRI6) => {
                    for e in b.nodes.chunks_exact(6) {
                        mid.insert(key(e[0], e[1]), e[3]);
                        mid.insert(key(e[1], e[2]), e[4]);
                        mid.insert(key(e[2], e[0]), e[5]);
                        tris.entry(b.entity_tag)
                            .or_default()
                            .push(([e[0], e[1], e[2]], [at(e[3]), at(e[4]), at(e[5])]));
                    }
                }
                (2, etype::TRI3) => {
                    for e in b.nodes.chunks_exact(3) {
                        // no mid-edge nodes: the flat triangle
                        tris.entry(b.entity_tag)
                            .or_default()
                            .push(([e[0], e[1], e[2]], [None; 3]));
                    }
                }
                (2, etype::QUAD9 | etype::QUAD8) => {
                    let k = b.nodes_per_element();
                    for e in b.nodes.chunks_exact(k) {
                        for j in 0..4 {
                            mid.insert(key(e[j], e[(j + 1) % 4]), e[4 + j]);
                        }
                        // the surface the quad covers, as two curved triangles about the
                        // diagonal 0-2, whose middle is the face node (for an 8-node quad,
                        // its serendipity centre)
                        let x: Option<Vec<DVec3>> = e.iter().map(|&t| at(t)).collect();
                        let Some(x) = x else { continue };
                        let centre = if k == 9 {
                            let mut c = [e[0], e[1], e[2], e[3]];
                            c.sort_unstable();
                            face.insert(c, e[8]);
                            x[8]
                        } else {
                            (x[4] + x[5] + x[6] + x[7]) * 0.5 - (x[0] + x[1] + x[2] + x[3]) * 0.25
                        };
                        let list = tris.entry(b.entity_tag).or_default();
                        list.push(([e[0], e[1], e[2]], [Some(x[4]), Some(x[5]), Some(centre)]));
                        list.push(([e[0], e[2], e[3]], [Some(centre), Some(x[6]), Some(x[7])]));
                    }
                }
                (1, etype::LINE3) => {
                    for e in b.nodes.chunks_exact(3) {
                        mid.insert(key(e[0], e[1]), e[2]);
                        curves
                            .entry(b.entity_tag)
                            .or_default()
                            .push([e[0], e[1], e[2]]);
                    }
                }
                _ => {}
            }
        }
        let surfaces = tris
            .into_par_iter()
            .map(|(s, list)| {
                let mut index: FastMap<u64, u32> = FastMap::default();
                let mut points = Vec::new();
                let mut flat = Vec::with_capacity(list.len());
                let mut six = Vec::with_capacity(list.len());
                let at = |t: u64| coords.at(t).unwrap_or(DVec3::ZERO);
                let mut node_tri = FastMap::default();
                for (ti, (t, _)) in list.iter().enumerate() {
                    for &n in t {
                        node_tri.entry(n).or_insert(ti as u32);
                    }
                }
                for (t, m) in &list {
                    let mut f = [0u32; 3];
                    for (k, &n) in t.iter().enumerate() {
                        f[k] = *index.entry(n).or_insert_with(|| {
                            points.push(at(n));
                            (points.len() - 1) as u32
                        });
                    }
                    flat.push(f);
                    let c = [at(t[0]), at(t[1]), at(t[2])];
                    let m = |k: usize, i: usize, j: usize| m[k].unwrap_or((c[i] + c[j]) * 0.5);
                    six.push([c[0], c[1], c[2], m(0, 0, 1), m(1, 1, 2), m(2, 2, 0)]);
                }
                (
                    s,
                    SurfaceGeometry {
                        locator: TriSurface::new(points, flat),
                        six,
                        node_tri,
                    },
                )
            })
            .collect();
        Geometry {
            input,
            nodes,
            mid,
            face,
            surfaces,
            curves,
        }
    }
}

/// The centre a serendipity (8-node) quad gives its middle: `Σ mid/2 − Σ corner/4`.
pub(super) fn serendipity_centre(x: &[DVec3; 9]) -> DVec3 {
    (x[4] + x[5] + x[6] + x[7]) * 0.5 - (x[0] + x[1] + x[2] + x[3]) * 0.25
}
