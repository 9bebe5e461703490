//! Mesh size fields h(x) and the adimensional edge length l^h (eq. 1).
//!
//! Three sources of h, in order of preference when comparing meshes:
//!
//! 1. [`SizeField::Expression`]: an analytic h(x, y, z) (the paper's examples). Exact and
//!    identical for every mesh measured with it.
//! 2. [`SizeField::Reference`]: sizes estimated from a *reference triangulation*, normally the
//!    triangle mesh that was recombined. The size at a reference node is the mean length of
//!    its incident edges; h at any point is the linear (barycentric) interpolation on the
//!    reference triangle closest to that point. Because the field belongs to the reference and
//!    not to the measured mesh, our output, Gmsh's output and the input triangulation itself
//!    are all measured against the *same* h, so their τ values compare directly. This is the
//!    field to use for "τ at most 2 points below the input's".
//! 3. [`SizeField::SelfEstimate`] (the default without a reference): h at each node of the
//!    measured mesh is the mean length of its own incident edges, linear along each edge.
//!    Quad edges of a recombined mesh are the triangle edges that were kept, so they have the
//!    triangulation's length ~h; no √2 factor is applied (the √2-long quad diagonals are not
//!    mesh edges). A self-estimate only measures how *uniform* the local edge lengths are
//!    (a perfectly graded mesh scores 100 % whatever its size), so it cannot tell a mesh at
//!    half the intended size from a good one; prefer a reference or an expression.
//!
//! Integration of eq. (1): with nodal sizes linear along the edge, ∫ 1/h is exact
//! (ln(h_b/h_a)/(h_b−h_a)); otherwise Simpson's rule on the two ends and the midpoint.

use super::locate::TriSurface;
use super::QualityError;
use crate::mesh::{etype, Mesh};
use evalexpr::error::EvalexprResultValue;
use evalexpr::{
    build_operator_tree, Context, DefaultNumericTypes, EvalexprError, EvalexprResult, Node, Value,
};
use glam::DVec3;
use rayon::prelude::*;

/// A compiled size expression h(x, y, z).
///
/// Syntax is `evalexpr`'s, with the variables `x`, `y`, `z`, the constant `pi` and the
/// functions `sin cos tan asin acos atan sinh cosh tanh exp ln log10 sqrt abs` (one argument),
/// `atan2(y, x)`, `pow(a, b)`, and evalexpr's `min`, `max`, `floor`, `ceil`, `round`, `^`.
/// Beware: integer literals divide as integers (`1/2` is 0); write `1.0/2`.
#[derive(Debug)]
pub struct SizeExpr {
    text: String,
    tree: Node<DefaultNumericTypes>,
}

struct Xyz {
    v: [Value<DefaultNumericTypes>; 4],
}

impl Context for Xyz {
    type NumericTypes = DefaultNumericTypes;

    fn get_value(&self, identifier: &str) -> Option<&Value<DefaultNumericTypes>> {
        match identifier {
            "x" => Some(&self.v[0]),
            "y" => Some(&self.v[1]),
            "z" => Some(&self.v[2]),
            "pi" => Some(&self.v[3]),
            _ => None,
        }
    }

    fn call_function(
        &self,
        identifier: &str,
        argument: &Value<DefaultNumericTypes>,
    ) -> EvalexprResultValue<DefaultNumericTypes> {
        let one = |f: fn(f64) -> f64| -> EvalexprResultValue<DefaultNumericTypes> {
            Ok(Value::Float(f(argument.as_number()?)))
        };
        let two = |f: fn(f64, f64) -> f64| -> EvalexprResultValue<DefaultNumericTypes> {
            let t = argument.as_fixed_len_tuple(2)?;
            Ok(Value::Float(f(t[0].as_number()?, t[1].as_number()?)))
        };
        match identifier {
            "sin" => one(f64::sin),
            "cos" => one(f64::cos),
            "tan" => one(f64::tan),
            "asin" => one(f64::asin),
            "acos" => one(f64::acos),
            "atan" => one(f64::atan),
            "sinh" => one(f64::sinh),
            "cosh" => one(f64::cosh),
            "tanh" => one(f64::tanh),
            "exp" => one(f64::exp),
            "ln" => one(f64::ln),
            "log10" => one(f64::log10),
            "sqrt" => one(f64::sqrt),
            "abs" => one(f64::abs),
            "atan2" => two(f64::atan2),
            "pow" => two(f64::powf),
            _ => Err(EvalexprError::FunctionIdentifierNotFound(
                identifier.to_string(),
            )),
        }
    }

    fn are_builtin_functions_disabled(&self) -> bool {
        false
    }

    fn set_builtin_functions_disabled(
        &mut self,
        _disabled: bool,
    ) -> EvalexprResult<(), DefaultNumericTypes> {
        Ok(())
    }
}

impl SizeExpr {
    /// Compiles `text` once. Fails with [`QualityError::SizeExpression`] naming the expression
    /// when it does not parse, or when evaluating it at the origin fails for a reason other
    /// than arithmetic (unknown variable or function, wrong types).
    pub fn new(text: &str) -> Result<Self, QualityError> {
        let tree = build_operator_tree::<DefaultNumericTypes>(text).map_err(|e| {
            QualityError::SizeExpression {
                expr: text.to_string(),
                message: e.to_string(),
            }
        })?;
        let s = SizeExpr {
            text: text.to_string(),
            tree,
        };
        if let Err(e) = s.tree.eval_number_with_context(&xyz(DVec3::ZERO)) {
            let arithmetic = matches!(
                e,
                EvalexprError::DivisionError { .. }
                    | EvalexprError::ModulationError { .. }
                    | EvalexprError::AdditionError { .. }
                    | EvalexprError::SubtractionError { .. }
                    | EvalexprError::MultiplicationError { .. }
            );
            if !arithmetic {
                return Err(QualityError::SizeExpression {
                    expr: text.to_string(),
                    message: e.to_string(),
                });
            }
        }
        Ok(s)
    }

    /// The expression as given.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// h at `p`; fails when evaluation fails or gives a non-positive or non-finite size.
    pub fn eval(&self, p: DVec3) -> Result<f64, QualityError> {
        let err = |message: String| QualityError::SizeValue {
            expr: self.text.clone(),
            point: p.to_array(),
            message,
        };
        let h = self
            .tree
            .eval_number_with_context(&xyz(p))
            .map_err(|e| err(e.to_string()))?;
        if h.is_finite() && h > 0.0 {
            Ok(h)
        } else {
            Err(err(format!("size {h} is not positive and finite")))
        }
    }
}

fn xyz(p: DVec3) -> Xyz {
    Xyz {
        v: [
            Value::Float(p.x),
            Value::Float(p.y),
            Value::Float(p.z),
            Value::Float(std::f64::consts::PI),
        ],
    }
}

/// Sizes at the nodes of a reference triangulation, interpolated on it.
#[derive(Debug, Clone)]
pub struct ReferenceSize {
    surface: TriSurface,
    h: Vec<f64>,
}

impl ReferenceSize {
    /// Builds the field from every 3-node triangle of `reference` (quads, if any, are split
    /// along a diagonal so a quad-only reference also works). `None` when the reference has
    /// no surface element. Elements naming a missing node are skipped.
    pub fn from_mesh(reference: &Mesh) -> Option<Self> {
        let index = reference.node_index();
        let mut local = vec![u32::MAX; 0];
        let mut points = Vec::new();
        let mut tris = Vec::new();
        let mut offsets = Vec::with_capacity(reference.node_blocks.len());
        let mut total = 0usize;
        for b in &reference.node_blocks {
            offsets.push(total);
            total += b.tags.len();
        }
        local.resize(total, u32::MAX);
        for block in &reference.element_blocks {
            if block.element_type != etype::TRI3 && block.element_type != etype::QUAD4 {
                continue;
            }
            for e in 0..block.len() {
                let nodes = block.element(e);
                let mut ids = [0u32; 4];
                let mut ok = true;
                for (k, &tag) in nodes.iter().enumerate() {
                    match index.get(tag) {
                        Some(r) => {
                            let g = offsets[r.block as usize] + r.index as usize;
                            if local[g] == u32::MAX {
                                local[g] = points.len() as u32;
                                points.push(DVec3::from_array(
                                    reference.node_blocks[r.block as usize].coords
                                        [r.index as usize],
                                ));
                            }
                            ids[k] = local[g];
                        }
                        None => ok = false,
                    }
                }
                if !ok {
                    continue;
                }
                tris.push([ids[0], ids[1], ids[2]]);
                if nodes.len() == 4 {
                    tris.push([ids[0], ids[2], ids[3]]);
                }
            }
        }
        if tris.is_empty() {
            return None;
        }
        let h = mean_incident_edge_length(&points, tris.iter().map(|t| &t[..]));
        Some(ReferenceSize {
            surface: TriSurface::new(points, tris),
            h,
        })
    }

    /// h at the point of the reference closest to `p`.
    pub fn at(&self, p: DVec3) -> f64 {
        match self.surface.closest(p) {
            Some(hit) => {
                let t = self.surface.triangle(hit.tri);
                (0..3).map(|k| hit.bary[k] * self.h[t[k] as usize]).sum()
            }
            None => 1.0,
        }
    }

    /// The reference triangulation the sizes live on.
    #[cfg(feature = "testing")]
    pub fn surface(&self) -> &TriSurface {
        &self.surface
    }

    /// Nodal sizes, indexed like the reference surface's points.
    pub fn nodal(&self) -> &[f64] {
        &self.h
    }
}

/// The mesh size field h used for τ (eq. 1-2). See the module documentation for which to use.
#[derive(Debug)]
pub enum SizeField {
    /// An analytic h(x, y, z).
    Expression(SizeExpr),
    /// Sizes from a reference triangulation (normally the recombined triangle mesh).
    Reference(ReferenceSize),
    /// Sizes from the measured mesh's own edge lengths.
    SelfEstimate,
}

impl SizeField {
    /// Short description for reports.
    pub fn describe(&self) -> String {
        match self {
            SizeField::Expression(e) => format!("expression h = {}", e.text()),
            SizeField::Reference(_) => {
                "reference triangulation (mean incident edge length, interpolated)".to_string()
            }
            SizeField::SelfEstimate => {
                "self-estimate (mean incident edge length of the measured mesh)".to_string()
            }
        }
    }
}

/// Mean length of the edges incident to each point, every distinct edge counted once
/// (an edge shared by two faces is not counted twice). Points without edges get 0. Faces
/// with a node out of range are left out.
///
/// O(corners): the neighbours of each point are gathered face by face (CSR; `faces` is
/// walked twice instead of collected) and deduplicated per point, in parallel over chunks
/// of points; the sums run over increasing neighbour index.
pub fn mean_incident_edge_length<'a>(
    points: &[DVec3],
    faces: impl Iterator<Item = &'a [u32]> + Clone,
) -> Vec<f64> {
    let n = points.len();
    let faces = faces.filter(|f| f.iter().all(|&v| (v as usize) < n));
    let mut start = vec![0usize; n + 1];
    for f in faces.clone() {
        for &v in f {
            start[v as usize + 1] += 2;
        }
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    // filling moves each point's start to the next point's; shifted back below
    let mut nbr = vec![0u32; start[n]];
    for f in faces {
        let m = f.len();
        for k in 0..m {
            let v = f[k] as usize;
            nbr[start[v]] = f[(k + 1) % m];
            nbr[start[v] + 1] = f[(k + m - 1) % m];
            start[v] += 2;
        }
    }
    start.copy_within(0..n, 1);
    start[0] = 0;
    let mut out = vec![0.0; n];
    // split the CSR payload at chunk boundaries so each chunk sorts its own points' lists
    let mut rest: &mut [u32] = &mut nbr;
    let mut chunks: Vec<(usize, &mut [u32])> = Vec::with_capacity(n.div_ceil(CHUNK));
    for c in (0..n).step_by(CHUNK) {
        let end = (c + CHUNK).min(n);
        let (head, tail) = rest.split_at_mut(start[end] - start[c]);
        chunks.push((c, head));
        rest = tail;
    }
    out.par_chunks_mut(CHUNK)
        .zip(chunks.into_par_iter())
        .for_each(|(hs, (c, lists))| {
            let base = start[c];
            for (i, h) in hs.iter_mut().enumerate() {
                let v = c + i;
                let list = &mut lists[start[v] - base..start[v + 1] - base];
                list.sort_unstable();
                let (mut sum, mut cnt) = (0.0, 0u32);
                for (i, &w) in list.iter().enumerate() {
                    if w as usize == v || (i > 0 && list[i - 1] == w) {
                        continue;
                    }
                    sum += points[v].distance(points[w as usize]);
                    cnt += 1;
                }
                *h = if cnt > 0 { sum / cnt as f64 } else { 0.0 };
            }
        });
    out
}

/// Points per parallel task of [`mean_incident_edge_length`].
const CHUNK: usize = 4096;

/// ∫₀¹ dt / h(t) for h linear from `ha` to `hb` (both > 0), exactly.
pub fn inverse_linear_integral(ha: f64, hb: f64) -> f64 {
    let d = hb - ha;
    if d.abs() <= 1e-9 * ha.max(hb) {
        // series of ln(1+u)/u around u = 0
        2.0 / (ha + hb)
    } else {
        (hb / ha).ln() / d
    }
}

/// Adimensional length l^h, eq. (1), by Simpson's rule from 1/h at both ends and the middle.
pub fn adimensional_length_simpson(len: f64, inv_ha: f64, inv_hm: f64, inv_hb: f64) -> f64 {
    len * (inv_ha + 4.0 * inv_hm + inv_hb) / 6.0
}

/// The term d_i of eq. (2): l − 1 for l < 1, 1/l − 1 otherwise (≤ 0, 0 only at l = 1).
pub fn tau_deviation(l: f64) -> f64 {
    if l < 1.0 {
        l - 1.0
    } else {
        1.0 / l - 1.0
    }
}

/// Efficiency index τ in percent, eq. (2), from adimensional edge lengths. `None` when empty.
#[cfg(any(test, feature = "testing"))]
pub fn tau_percent(lengths: impl Iterator<Item = f64>) -> Option<f64> {
    let mut n = 0usize;
    let mut sum = 0.0;
    for l in lengths {
        n += 1;
        sum += tau_deviation(l);
    }
    (n > 0).then(|| 100.0 * (sum / n as f64).exp())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against a direct count over the distinct edges, on a grid of triangles and quads
    /// spanning several parallel chunks of points, with a point on no face and a face
    /// naming a point out of range (left out).
    #[test]
    fn mean_incident_edge_length_counts_each_distinct_edge_once() {
        let (nx, ny) = (90usize, 100usize);
        let n = nx * ny + 1;
        assert!(n > 2 * CHUNK);
        let points: Vec<DVec3> = (0..n)
            .map(|k| {
                let jitter = 0.1 * ((k * 7919) % 13) as f64;
                DVec3::new((k % nx) as f64 + jitter, (k / nx) as f64, 0.0)
            })
            .collect();
        let id = |i: usize, j: usize| (j * nx + i) as u32;
        let mut faces: Vec<Vec<u32>> = Vec::new();
        for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
                if (i + j) % 3 == 0 {
                    faces.push(vec![a, b, c, d]);
                } else {
                    faces.push(vec![a, b, c]);
                    faces.push(vec![a, c, d]);
                }
            }
        }
        faces.push(vec![0, 1, n as u32 + 5]);
        let h = mean_incident_edge_length(&points, faces.iter().map(|f| &f[..]));
        let mut nbrs = vec![std::collections::BTreeSet::new(); n];
        for f in faces.iter().filter(|f| f.iter().all(|&v| (v as usize) < n)) {
            for k in 0..f.len() {
                let (a, b) = (f[k] as usize, f[(k + 1) % f.len()] as usize);
                nbrs[a].insert(b);
                nbrs[b].insert(a);
            }
        }
        for (v, set) in nbrs.iter().enumerate() {
            let sum: f64 = set.iter().map(|&w| points[v].distance(points[w])).sum();
            let want = if set.is_empty() {
                0.0
            } else {
                sum / set.len() as f64
            };
            assert_eq!(h[v], want, "point {v}");
        }
        assert_eq!(h[n - 1], 0.0);
    }

    #[test]
    fn expression_evaluates_paper_size_field() {
        let e = SizeExpr::new("0.1 + 0.08 * sin(3 * x) * cos(6 * y)").unwrap();
        let p = DVec3::new(0.3, 0.2, 0.0);
        let h = e.eval(p).unwrap();
        assert!((h - (0.1 + 0.08 * (0.9f64).sin() * (1.2f64).cos())).abs() < 1e-15);
    }

    #[test]
    fn expression_errors_name_the_expression() {
        let e = SizeExpr::new("0.1 + w").unwrap_err();
        assert!(e.to_string().contains("0.1 + w"), "{e}");
        let e = SizeExpr::new("0.1 +* (").unwrap_err();
        assert!(e.to_string().contains("0.1 +* ("), "{e}");
        let neg = SizeExpr::new("x - 1.0").unwrap();
        let e = neg.eval(DVec3::ZERO).unwrap_err();
        assert!(e.to_string().contains("x - 1.0"), "{e}");
    }

    #[test]
    fn exact_integral_matches_simpson_on_smooth_data() {
        let (ha, hb) = (0.1, 0.3);
        let exact = inverse_linear_integral(ha, hb);
        // fine Simpson
        let n = 1000;
        let mut s = 0.0;
        for i in 0..n {
            let t0 = i as f64 / n as f64;
            let t1 = (i + 1) as f64 / n as f64;
            let f = |t: f64| 1.0 / (ha + (hb - ha) * t);
            s += adimensional_length_simpson(t1 - t0, f(t0), f(0.5 * (t0 + t1)), f(t1));
        }
        assert!((exact - s).abs() < 1e-9, "{exact} vs {s}");
        assert!((inverse_linear_integral(0.2, 0.2) - 5.0).abs() < 1e-12);
    }
}
