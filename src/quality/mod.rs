//! Quality measures of the paper's section 2 (Remacle et al. 2012), for any mesh:
//! the quad quality η (eq. 3, [`eta()`]), its worst value η_w and mean η̄, the degrees of
//! interior vertices (Table I: d4 %, d_min, d_max) and the efficiency index τ (eq. 1-2)
//! against a size field ([`SizeField`]).
//!
//! [`report`] measures every surface entity separately and the whole mesh; the result prints
//! as a table ([`std::fmt::Display`]) or as JSON ([`QualityReport::to_json`]).
//!
//! **Invariant:** measuring never changes the mesh and never panics on a mesh read from a
//! file (elements naming missing nodes are skipped and counted).

internal! {
    mod eta;
    mod jacobian;
    mod locate;
    mod size;
    mod view;
}

#[cfg(feature = "testing")]
pub use eta::eta_signed_fast;
#[cfg(not(feature = "testing"))]
pub(crate) use eta::eta_signed_fast;
pub use eta::{eta, eta_signed};
pub use size::{ReferenceSize, SizeExpr, SizeField};
pub use view::{add_views, view_mesh};

use crate::mesh::{etype, Mesh, NodeTable};
use glam::DVec3;
use serde::Serialize;
use std::fmt;

/// Errors of the quality module.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum QualityError {
    /// The size expression does not compile (or names unknown variables/functions).
    #[error("size expression `{expr}`: {message}")]
    SizeExpression {
        /// The expression as given.
        expr: String,
        /// What the expression parser said.
        message: String,
    },
    /// The size expression failed or gave a non-positive size at some point.
    #[error("size expression `{expr}` at ({}, {}, {}): {message}", point[0], point[1], point[2])]
    SizeValue {
        /// The expression as given.
        expr: String,
        /// Where it was evaluated.
        point: [f64; 3],
        /// What went wrong.
        message: String,
    },
}

/// Statistics of one surface entity, or of the whole mesh.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SurfaceQuality {
    /// Surface entity tag; `None` for the whole-mesh summary.
    pub surface: Option<i32>,
    /// Number of quadrangles (4-node, and 8- and 9-node measured as below).
    pub quads: usize,
    /// Number of 3-node triangles (left over after recombination, or the input itself).
    pub triangles: usize,
    /// 2D elements of other types (high order, ...), not measured.
    pub other_elements: usize,
    /// Worst quad quality η_w (eq. 3); `None` without quads.
    pub eta_worst: Option<f64>,
    /// Mean quad quality η̄ (eq. 3); `None` without quads.
    pub eta_mean: Option<f64>,
    /// Smallest scaled Jacobian over the quads (for a 4-node quad
    /// the minimum over its corners of the normalized cross product of its two edges,
    /// signed about the quad's normal; for 8- and 9-node quads the minimum at its nodes;
    /// Gmsh's `minSIGE`); `None` without quads.
    pub sj_min: Option<f64>,
    /// Mean over the quads of their scaled Jacobian; `None` without quads.
    pub sj_mean: Option<f64>,
    /// Histogram of η in ten bins [0, 0.1), ..., [0.9, 1].
    pub eta_histogram: [usize; 10],
    /// Interior vertices measured for degrees: not on a curve, a point, or the boundary of
    /// the surface mesh, and surrounded by quads only.
    pub interior_vertices: usize,
    /// Percentage of those vertices with exactly four quads around them (d4 in Table I).
    pub d4_percent: Option<f64>,
    /// Smallest vertex degree (number of quads around an interior vertex).
    pub d_min: Option<usize>,
    /// Largest vertex degree.
    pub d_max: Option<usize>,
    /// Number of distinct mesh edges of the surface elements used for τ.
    pub edges: usize,
    /// Efficiency index τ in percent, eq. (2); `None` without edges.
    pub tau_percent: Option<f64>,
    /// Smallest and largest adimensional edge length l^h (eq. 1).
    pub lh_min: Option<f64>,
    /// Largest adimensional edge length l^h (eq. 1).
    pub lh_max: Option<f64>,
}

/// What [`report`] returns: one entry per surface entity plus the whole-mesh summary.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct QualityReport {
    /// The size field τ was measured against.
    pub size_field: String,
    /// Per surface entity, by increasing tag.
    pub surfaces: Vec<SurfaceQuality>,
    /// The whole mesh (edges shared by two surfaces counted once).
    pub total: SurfaceQuality,
    /// Elements skipped because they name a node that does not exist.
    pub skipped_elements: usize,
}

impl QualityReport {
    /// The report as pretty-printed JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"))
    }
}

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map_or("-".to_string(), |x| format!("{x:.digits$}"))
}

fn opt_u(v: Option<usize>) -> String {
    v.map_or("-".to_string(), |x| x.to_string())
}

impl fmt::Display for QualityReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "size field: {}", self.size_field)?;
        writeln!(
            f,
            "{:>8} {:>9} {:>7} {:>6} {:>6} {:>6} {:>6} {:>6} {:>5} {:>5} {:>7} {:>7} {:>7}",
            "surface",
            "quads",
            "tris",
            "eta_w",
            "eta_m",
            "sj_min",
            "sj_m",
            "d4%",
            "dmin",
            "dmax",
            "tau%",
            "lh_min",
            "lh_max"
        )?;
        let row = |f: &mut fmt::Formatter<'_>, name: String, s: &SurfaceQuality| {
            writeln!(
                f,
                "{:>8} {:>9} {:>7} {:>6} {:>6} {:>6} {:>6} {:>6} {:>5} {:>5} {:>7} {:>7} {:>7}",
                name,
                s.quads,
                s.triangles,
                opt(s.eta_worst, 3),
                opt(s.eta_mean, 3),
                opt(s.sj_min, 3),
                opt(s.sj_mean, 3),
                opt(s.d4_percent, 1),
                opt_u(s.d_min),
                opt_u(s.d_max),
                opt(s.tau_percent, 1),
                opt(s.lh_min, 2),
                opt(s.lh_max, 2),
            )
        };
        for s in &self.surfaces {
            row(f, s.surface.map_or("-".into(), |t| t.to_string()), s)?;
        }
        row(f, "all".into(), &self.total)?;
        if self.skipped_elements > 0 {
            writeln!(
                f,
                "{} element(s) skipped: they name missing nodes",
                self.skipped_elements
            )?;
        }
        Ok(())
    }
}

/// Per-quad quality η (eq. 3) of every quadrangle (4-node, and 8- and 9-node on their
/// corners), as `(element tag, η)` in file order. Quads naming missing nodes are skipped.
pub fn quad_etas(mesh: &Mesh) -> Vec<(u64, f64)> {
    let nodes = NodeTable::new(mesh);
    let mut out = Vec::new();
    for b in &mesh.element_blocks {
        if !matches!(b.element_type, etype::QUAD4 | etype::QUAD8 | etype::QUAD9) {
            continue;
        }
        for e in 0..b.len() {
            let el = b.element(e);
            let mut p = [DVec3::ZERO; 4];
            if el
                .iter()
                .zip(p.iter_mut())
                .all(|(&t, q)| nodes.id(t).map(|i| *q = nodes.coords[i as usize]).is_some())
            {
                out.push((b.tags[e], eta(&p)));
            }
        }
    }
    out
}

#[derive(Default)]
struct Acc {
    quads: usize,
    triangles: usize,
    other: usize,
    eta_min: f64,
    eta_sum: f64,
    sj_min: f64,
    sj_sum: f64,
    hist: [usize; 10],
    deg: Vec<usize>,
    edges: usize,
    dsum: f64,
    lmin: f64,
    lmax: f64,
}

impl Acc {
    fn new() -> Self {
        Acc {
            eta_min: f64::INFINITY,
            sj_min: f64::INFINITY,
            lmin: f64::INFINITY,
            lmax: 0.0,
            ..Default::default()
        }
    }
    fn add_quad(&mut self, e: f64, sj: f64) {
        self.quads += 1;
        self.eta_min = self.eta_min.min(e);
        self.eta_sum += e;
        self.sj_min = self.sj_min.min(sj);
        self.sj_sum += sj;
        self.hist[((e * 10.0) as usize).min(9)] += 1;
    }
    fn add_degree(&mut self, d: usize) {
        if self.deg.len() <= d {
            self.deg.resize(d + 1, 0);
        }
        self.deg[d] += 1;
    }
    fn add_edge(&mut self, l: f64) {
        self.edges += 1;
        self.dsum += size::tau_deviation(l);
        self.lmin = self.lmin.min(l);
        self.lmax = self.lmax.max(l);
    }
    fn finish(self, surface: Option<i32>) -> SurfaceQuality {
        let nint: usize = self.deg.iter().sum();
        SurfaceQuality {
            surface,
            quads: self.quads,
            triangles: self.triangles,
            other_elements: self.other,
            eta_worst: (self.quads > 0).then_some(self.eta_min),
            eta_mean: (self.quads > 0).then(|| self.eta_sum / self.quads as f64),
            sj_min: (self.quads > 0).then_some(self.sj_min),
            sj_mean: (self.quads > 0).then(|| self.sj_sum / self.quads as f64),
            eta_histogram: self.hist,
            interior_vertices: nint,
            d4_percent: (nint > 0)
                .then(|| 100.0 * self.deg.get(4).copied().unwrap_or(0) as f64 / nint as f64),
            d_min: self.deg.iter().position(|&c| c > 0),
            d_max: self.deg.iter().rposition(|&c| c > 0),
            edges: self.edges,
            tau_percent: (self.edges > 0).then(|| 100.0 * (self.dsum / self.edges as f64).exp()),
            lh_min: (self.edges > 0).then_some(self.lmin),
            lh_max: (self.edges > 0).then_some(self.lmax),
        }
    }
}

/// Measures `mesh` against the size field `size`: per surface entity and overall.
///
/// Counted: quads (η, eq. 3, with [`eta()`], on the corners; the scaled Jacobian,
/// on all nodes), 3-node and 6-node triangles, other 2D elements.
/// Vertex degrees (Table I) are taken over *interior* vertices: not in any point or line
/// element, not classified on a point or curve, not on an edge used by other than two
/// surface elements, and surrounded by quads only (in a mixed mesh a vertex touching a
/// triangle has no quad degree). τ (eq. 2) runs over the distinct edges of the surface
/// elements, each with l^h from eq. (1) (see [`SizeField`] for the choice of
/// field). Fails only when a size expression fails somewhere.
pub fn report(mesh: &Mesh, size: &SizeField) -> Result<QualityReport, QualityError> {
    let nodes = NodeTable::new(mesh);
    let nn = nodes.coords.len();
    let mut surf_tags: Vec<i32> = mesh
        .element_blocks
        .iter()
        .filter(|b| crate::mesh::element_dim(b.element_type) == Some(2))
        .map(|b| b.entity_tag)
        .collect();
    surf_tags.sort_unstable();
    surf_tags.dedup();
    let sid = |tag: i32| surf_tags.binary_search(&tag).unwrap_or(0) as u32;

    let mut accs: Vec<Acc> = surf_tags.iter().map(|_| Acc::new()).collect();
    let mut total = Acc::new();
    let mut skipped = 0usize;
    // faces: (surface id, node count, nodes)
    let mut faces: Vec<(u32, u8, [u32; 4])> = Vec::new();
    let mut on_curve = vec![false; nn];
    for (bi, b) in mesh.node_blocks.iter().enumerate() {
        if b.entity_dim < 2 {
            let start = nodes.block_start[bi] as usize;
            on_curve[start..start + b.tags.len()].fill(true);
        }
    }
    for b in &mesh.element_blocks {
        let dim = crate::mesh::element_dim(b.element_type);
        if matches!(dim, Some(0) | Some(1)) {
            for &t in &b.nodes {
                if let Some(i) = nodes.id(t) {
                    on_curve[i as usize] = true;
                }
            }
            continue;
        }
        if dim != Some(2) {
            continue;
        }
        let s = sid(b.entity_tag);
        let full = b.nodes_per_element();
        let k = match b.element_type {
            // second-order elements are measured on their corners
            etype::TRI3 | etype::TRI6 => 3,
            etype::QUAD4 | etype::QUAD8 | etype::QUAD9 => 4,
            _ => {
                accs[s as usize].other += b.len();
                total.other += b.len();
                continue;
            }
        };
        for e in 0..b.len() {
            let el = &b.element(e)[..k];
            let mut ids = [0u32; 4];
            if !el
                .iter()
                .zip(ids.iter_mut())
                .all(|(&t, id)| nodes.id(t).map(|i| *id = i).is_some())
            {
                skipped += 1;
                continue;
            }
            if k == 4 {
                // the scaled Jacobian needs every node of a second-order quad
                let all: Option<Vec<DVec3>> = b.element(e)[..full]
                    .iter()
                    .map(|&t| nodes.id(t).map(|i| nodes.coords[i as usize]))
                    .collect();
                let Some(sj) = all.as_deref().and_then(view::scaled_jacobian) else {
                    skipped += 1;
                    continue;
                };
                let p = ids.map(|i| nodes.coords[i as usize]);
                let q = eta(&p);
                accs[s as usize].add_quad(q, sj);
                total.add_quad(q, sj);
            } else {
                accs[s as usize].triangles += 1;
                total.triangles += 1;
            }
            faces.push((s, k as u8, ids));
        }
    }

    // Edges: (a, b, surface) sorted; multiplicity over the whole mesh decides boundaries.
    let mut edges: Vec<(u32, u32, u32)> = Vec::with_capacity(faces.len() * 4);
    let mut face_count = vec![0u32; nn];
    let mut quad_count = vec![0u32; nn];
    const MIXED: u32 = u32::MAX;
    const UNSET: u32 = u32::MAX - 1;
    let mut node_surf = vec![UNSET; nn];
    for &(s, k, ids) in &faces {
        let k = k as usize;
        for i in 0..k {
            let (a, b) = (ids[i], ids[(i + 1) % k]);
            edges.push((a.min(b), a.max(b), s));
            let v = ids[i] as usize;
            face_count[v] += 1;
            if k == 4 {
                quad_count[v] += 1;
            }
            node_surf[v] = match node_surf[v] {
                UNSET => s,
                x if x == s => s,
                _ => MIXED,
            };
        }
    }
    edges.sort_unstable();
    let mut boundary = on_curve;
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j].0 == edges[i].0 && edges[j].1 == edges[i].1 {
            j += 1;
        }
        if j - i != 2 {
            boundary[edges[i].0 as usize] = true;
            boundary[edges[i].1 as usize] = true;
        }
        i = j;
    }
    for v in 0..nn {
        if face_count[v] == 0 || boundary[v] || quad_count[v] != face_count[v] {
            continue;
        }
        let d = quad_count[v] as usize;
        total.add_degree(d);
        if node_surf[v] < MIXED - 1 {
            accs[node_surf[v] as usize].add_degree(d);
        }
    }

    // Size at nodes (1/h), then l^h per distinct edge.
    let used: Vec<bool> = face_count.iter().map(|&c| c > 0).collect();
    let lengths = edge_lengths(&nodes.coords, &used, &faces, &edges, size)?;
    let mut i = 0;
    while i < edges.len() {
        let (a, b, _) = edges[i];
        let l = lengths[i];
        total.add_edge(l);
        let mut j = i;
        let mut last_s = u32::MAX;
        while j < edges.len() && edges[j].0 == a && edges[j].1 == b {
            if edges[j].2 != last_s {
                accs[edges[j].2 as usize].add_edge(l);
                last_s = edges[j].2;
            }
            j += 1;
        }
        i = j;
    }

    Ok(QualityReport {
        size_field: size.describe(),
        surfaces: accs
            .into_iter()
            .zip(&surf_tags)
            .map(|(a, &t)| a.finish(Some(t)))
            .collect(),
        total: total.finish(None),
        skipped_elements: skipped,
    })
}

/// l^h (eq. 1) for the first occurrence of every distinct edge in the sorted `edges`
/// (entries of repeated edges hold copies).
fn edge_lengths(
    coords: &[DVec3],
    used: &[bool],
    faces: &[(u32, u8, [u32; 4])],
    edges: &[(u32, u32, u32)],
    size: &SizeField,
) -> Result<Vec<f64>, QualityError> {
    let mut out = vec![0.0; edges.len()];
    let nodal_h: Vec<f64> = match size {
        SizeField::SelfEstimate => size::mean_incident_edge_length(
            coords,
            faces.iter().map(|(_, k, ids)| &ids[..*k as usize]),
        ),
        SizeField::Reference(r) => coords
            .iter()
            .zip(used)
            .map(|(&p, &u)| if u { r.at(p) } else { 0.0 })
            .collect(),
        SizeField::Expression(e) => {
            let mut h = vec![0.0; coords.len()];
            for (v, (&p, &u)) in coords.iter().zip(used).enumerate() {
                if u {
                    h[v] = e.eval(p)?;
                }
            }
            h
        }
    };
    let mut i = 0;
    while i < edges.len() {
        let (a, b, _) = edges[i];
        let (pa, pb) = (coords[a as usize], coords[b as usize]);
        let len = pa.distance(pb);
        let (ha, hb) = (nodal_h[a as usize], nodal_h[b as usize]);
        let l = match size {
            SizeField::SelfEstimate => {
                if ha > 0.0 && hb > 0.0 {
                    len * size::inverse_linear_integral(ha, hb)
                } else {
                    0.0
                }
            }
            SizeField::Reference(r) => {
                let hm = r.at(0.5 * (pa + pb));
                size::adimensional_length_simpson(len, 1.0 / ha, 1.0 / hm, 1.0 / hb)
            }
            SizeField::Expression(e) => {
                let hm = e.eval(0.5 * (pa + pb))?;
                size::adimensional_length_simpson(len, 1.0 / ha, 1.0 / hm, 1.0 / hb)
            }
        };
        let mut j = i;
        while j < edges.len() && edges[j].0 == a && edges[j].1 == b {
            out[j] = l;
            j += 1;
        }
        i = j;
    }
    Ok(out)
}
