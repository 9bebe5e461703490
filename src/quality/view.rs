//! Quality a user can see in Gmsh: the mesh with post-processing views, `$ElementData`
//! "eta" (eq. 3, on the corners) and "scaled jacobian" per quadrangle, and `$NodeData`
//! "valence" (quadrangles at each node), written as MSH 4.1 ASCII so that `gmsh FILE`
//! opens it coloured (`blossomquad quality MESH --view OUT.msh`).
//!
//! The scaled Jacobian of a 4-node quad is the minimum over its corners of the cross
//! product of the two edges leaving the corner, divided by their lengths, measured about
//! the quad's straight-sided normal (the diagonals' cross product); of an 8- or 9-node quad,
//! the minimum at its nodes of `det J / (|∂x/∂ξ| |∂x/∂η|)` about the same normal
//! ([`super::jacobian::min_scaled_jacobian_at_nodes`]).
//!
//! [`add_views`] appends the same views to a mesh about to be written (`blossomquad IN -o
//! OUT --quality-view`, [`crate::Options::quality_view`]), encoded for the output's
//! encoding.
//!
//! **Invariant:** the measured mesh is not changed ([`add_views`] only appends data
//! sections); the view mesh is a copy whose data sections are replaced by the views.

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

/// Scaled Jacobian of a quadrangle given all its nodes in Gmsh order: 4 nodes
/// ([`quad4_scaled_jacobian`]), 8 or 9 nodes (the minimum at the nodes,
/// [`super::jacobian::min_scaled_jacobian_at_nodes`], with an 8-node quad's centre
/// taken as its serendipity centre). These are the values Gmsh reports as `minSIGE`;
/// Gmsh's `minSJ` is a lower bound (from Bézier coefficients) and can be well below them
/// on distorted quads. `None` for another node count.
pub fn scaled_jacobian(pts: &[DVec3]) -> Option<f64> {
    match pts.len() {
        4 => Some(quad4_scaled_jacobian(&[pts[0], pts[1], pts[2], pts[3]])),
        8 | 9 => {
            let mut x = [DVec3::ZERO; 9];
            x[..8].copy_from_slice(&pts[..8]);
            x[8] = if pts.len() == 9 {
                pts[8]
            } else {
                (x[4] + x[5] + x[6] + x[7]) * 0.5 - (x[0] + x[1] + x[2] + x[3]) * 0.25
            };
            Some(super::jacobian::min_scaled_jacobian_at_nodes(&x))
        }
        _ => None,
    }
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
        if !matches!(b.element_type, etype::QUAD4 | etype::QUAD8 | etype::QUAD9) {
            continue;
        }
        for i in 0..b.len() {
            let el = b.element(i);
            let pts: Option<Vec<DVec3>> = el.iter().map(|&t| at(t)).collect();
            let Some(pts) = pts else { continue };
            let corners = [pts[0], pts[1], pts[2], pts[3]];
            let Some(sj) = scaled_jacobian(&pts) else {
                continue;
            };
            elems.push((b.tags[i], crate::quality::eta(&corners), sj));
            for &t in &el[..4] {
                *valence.entry(t).or_insert(0) += 1;
            }
        }
    }
    (elems, valence.into_iter().collect())
}

/// One data section body: `name` and the header (ASCII in every MSH version), then one
/// entry per `(tag, value)`: a `tag value` line, or in binary a 4-byte tag and an 8-byte
/// value (as Gmsh writes both in MSH 2.2 and 4.1). Gmsh reads data tags as 32-bit
/// integers: rows whose tag does not fit are left out.
fn body(name: &str, rows: &[(u64, f64)], binary: bool) -> Vec<u8> {
    let rows: Vec<(i32, f64)> = rows
        .iter()
        .filter_map(|&(t, v)| i32::try_from(t).ok().map(|t| (t, v)))
        .collect();
    let mut s = String::new();
    // 1 string tag (the name), 1 real tag (time), 3 integer tags (step, components, count)
    let _ = writeln!(s, "1\n\"{name}\"\n1\n0\n3\n0\n1\n{}", rows.len());
    let mut out = s.into_bytes();
    if binary {
        out.reserve(rows.len() * 12 + 1);
        for (t, v) in rows {
            out.extend_from_slice(&t.to_le_bytes());
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.push(b'\n');
    } else {
        let mut s = String::with_capacity(rows.len() * 24);
        for (t, v) in rows {
            let _ = writeln!(s, "{t} {v}");
        }
        out.extend_from_slice(s.as_bytes());
    }
    out
}

/// The three views of `mesh` ("eta" and "scaled jacobian" per quadrangle, "valence" per
/// corner node) as data sections encoded binary or ASCII ([`DataSection::encoded_binary`]
/// set: they are written into any MSH version of that encoding).
pub fn view_sections(mesh: &Mesh, binary: bool) -> Vec<DataSection> {
    let (elems, valence) = quad_measures(mesh);
    let section = |kind, name, rows: Vec<(u64, f64)>| DataSection {
        kind,
        body: body(name, &rows, binary),
        encoded_binary: Some(binary),
    };
    vec![
        section(
            DataKind::Element,
            "eta",
            elems.iter().map(|e| (e.0, e.1)).collect(),
        ),
        section(
            DataKind::Element,
            "scaled jacobian",
            elems.iter().map(|e| (e.0, e.2)).collect(),
        ),
        section(
            DataKind::Node,
            "valence",
            valence.iter().map(|&(t, v)| (t, v as f64)).collect(),
        ),
    ]
}

/// Appends the three views to `mesh`'s data sections (after those it has), encoded
/// binary or ASCII: pass the encoding the mesh will be written in.
pub fn add_views(mesh: &mut Mesh, binary: bool) {
    let views = view_sections(mesh, binary);
    mesh.data_sections.extend(views);
}

/// A copy of `mesh` holding only the three views as data sections, to be written as
/// MSH 4.1 ASCII (its format is set so).
pub fn view_mesh(mesh: &Mesh) -> Mesh {
    let mut out = mesh.clone();
    out.format = Some(MshFormat {
        version: MshVersion::V41,
        binary: false,
    });
    out.data_sections = view_sections(mesh, false);
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

    #[test]
    fn binary_bodies_hold_a_four_byte_tag_and_an_eight_byte_value_per_row() {
        let rows = [(7u64, 0.25f64), (1 << 40, 1.0), (9, -0.5)];
        let b = body("eta", &rows, true);
        let header = b"1\n\"eta\"\n1\n0\n3\n0\n1\n2\n";
        assert_eq!(&b[..header.len()], header, "the tag beyond i32 is left out");
        let data = &b[header.len()..];
        assert_eq!(data.len(), 2 * 12 + 1);
        assert_eq!(data[..4], 7i32.to_le_bytes());
        assert_eq!(data[4..12], 0.25f64.to_le_bytes());
        assert_eq!(data[12..16], 9i32.to_le_bytes());
        assert_eq!(data[16..24], (-0.5f64).to_le_bytes());
        assert_eq!(data[24], b'\n');
        let a = String::from_utf8(body("eta", &rows, false)).expect("ASCII");
        assert!(a.ends_with("\n2\n7 0.25\n9 -0.5\n"), "{a}");
    }
}
