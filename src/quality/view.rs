//! Quality a user can see in Gmsh: the mesh with post-processing views, `$ElementData`
//! "eta" (eq. 3, on the corners) and "scaled jacobian" per quadrangle, and `$NodeData`
//! "valence" (quadrangles at each node), written as MSH 4.1 ASCII so that `gmsh FILE`
//! opens it coloured (`blossomquad quality MESH --view OUT.msh`).
//!
//! The scaled Jacobian of a 4-node quad is the minimum over its corners of the cross
//! product of the two edges leaving the corner, divided by their lengths, measured about
//! the quad's straight-sided normal (the diagonals' cross product); of an 8- or 9-node quad,
//! the minimum at its nodes of `det J / (|∂x/∂ξ| |∂x/∂η|)` about the same normal
//! ([`crate::high_order::min_scaled_jacobian_at_nodes`]).
//!
//! **Invariant:** the measured mesh is not changed; the view mesh is a copy whose data
//! sections are replaced by the views.

use std::fmt::Write as _;

use glam::DVec3;

use crate::mesh::{etype, DataKind, DataSection, Mesh, MshFormat, MshVersion};

/// Scaled Jacobian of a 4-node quad (minimum over its corners, see the module doc).
pub fn quad4_scaled_jacobian(p: &[DVec3; 4]) -> f64 {
    let n = (p[2] - p[0]).cross(p[3] - p[1]).normalize_or_zero();
    (0..4)
        .map(|i| {
            let a = p[(i + 1) % 4] - p[i];
            let b = p[(i + 3) % 4] - p[i];
            let d = a.length() * b.length();
            if d > 0.0 {
                a.cross(b).dot(n) / d
            } else {
                0.0
            }
        })
        .fold(f64::INFINITY, f64::min)
}

/// `(element tag, η, scaled Jacobian)` per quadrangle.
pub type QuadMeasures = Vec<(u64, f64, f64)>;

/// `(element tag, η, scaled Jacobian)` of every quadrangle (4, 8 and 9 nodes) whose nodes
/// all exist, in file order; and `(node tag, quadrangles at it)` for every corner node.
pub fn quad_measures(mesh: &Mesh) -> (QuadMeasures, Vec<(u64, usize)>) {
    let index = mesh.node_index();
    let at = |t: u64| {
        index
            .get(t)
            .map(|r| DVec3::from_array(mesh.node_blocks[r.block as usize].coords[r.index as usize]))
    };
    let mut elems = Vec::new();
    let mut valence: std::collections::BTreeMap<u64, usize> = Default::default();
    for b in &mesh.element_blocks {
        let k = match b.element_type {
            etype::QUAD4 => 4,
            etype::QUAD8 => 8,
            etype::QUAD9 => 9,
            _ => continue,
        };
        for i in 0..b.len() {
            let el = b.element(i);
            let pts: Option<Vec<DVec3>> = el.iter().map(|&t| at(t)).collect();
            let Some(pts) = pts else { continue };
            let corners = [pts[0], pts[1], pts[2], pts[3]];
            let sj = if k == 4 {
                quad4_scaled_jacobian(&corners)
            } else {
                let mut x = [DVec3::ZERO; 9];
                x[..8].copy_from_slice(&pts[..8]);
                x[8] = if k == 9 {
                    pts[8]
                } else {
                    (x[4] + x[5] + x[6] + x[7]) * 0.5 - (x[0] + x[1] + x[2] + x[3]) * 0.25
                };
                crate::high_order::min_scaled_jacobian_at_nodes(&x)
            };
            elems.push((b.tags[i], crate::quality::eta(&corners), sj));
            for &t in &el[..4] {
                *valence.entry(t).or_insert(0) += 1;
            }
        }
    }
    (elems, valence.into_iter().collect())
}

/// One data section body (MSH 4.1 ASCII): `name`, then `tag value` lines.
fn body<T: std::fmt::Display>(
    name: &str,
    rows: impl ExactSizeIterator<Item = (u64, T)>,
) -> Vec<u8> {
    let mut s = String::new();
    // 1 string tag (the name), 1 real tag (time), 3 integer tags (step, components, count)
    let _ = writeln!(s, "1\n\"{name}\"\n1\n0\n3\n0\n1\n{}", rows.len());
    for (t, v) in rows {
        let _ = writeln!(s, "{t} {v}");
    }
    s.into_bytes()
}

/// A copy of `mesh` holding only the three views as data sections, to be written as
/// MSH 4.1 ASCII (its format is set so).
pub fn view_mesh(mesh: &Mesh) -> Mesh {
    let (elems, valence) = quad_measures(mesh);
    let mut out = mesh.clone();
    out.format = Some(MshFormat {
        version: MshVersion::V41,
        binary: false,
    });
    out.data_sections = vec![
        DataSection {
            kind: DataKind::Element,
            body: body("eta", elems.iter().map(|e| (e.0, e.1))),
        },
        DataSection {
            kind: DataKind::Element,
            body: body("scaled jacobian", elems.iter().map(|e| (e.0, e.2))),
        },
        DataSection {
            kind: DataKind::Node,
            body: body("valence", valence.iter().copied()),
        },
    ];
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scaled_jacobian_of_squares_and_rhombi() {
        let p = |x: f64, y: f64| DVec3::new(x, y, 0.0);
        let square = [p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)];
        assert!((quad4_scaled_jacobian(&square) - 1.0).abs() < 1e-12);
        // a 60/120 degree rhombus: sin 60
        let h = 3f64.sqrt() / 2.0;
        let rhombus = [p(0.0, 0.0), p(1.0, 0.0), p(1.5, h), p(0.5, h)];
        assert!((quad4_scaled_jacobian(&rhombus) - h).abs() < 1e-12);
        // a reflex corner gives a negative value
        let dart = [p(0.0, 0.0), p(2.0, 0.0), p(0.5, 0.5), p(0.0, 2.0)];
        assert!(quad4_scaled_jacobian(&dart) < 0.0);
    }
}
