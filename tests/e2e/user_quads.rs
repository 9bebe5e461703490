//! Surfaces the user meshed with quads alone (a graded transfinite surface, an extruded
//! boundary layer) beside a triangle surface: only the triangles are recombined; the quad
//! surfaces' nodes and quads are written as read, unless `--smooth-quads` asks for them to
//! be optimized too.

use crate::common;

use blossomquad::mesh::{etype, Mesh};
use common::{blossomquad, generate_geo, repo_dir, Variant};
use std::path::Path;

/// The surfaces of `mesh` holding quads and no triangle.
fn quad_surfaces(mesh: &Mesh) -> Vec<i32> {
    let on = |t: u32| -> Vec<i32> {
        mesh.element_blocks
            .iter()
            .filter(|b| b.entity_dim == 2 && b.element_type == t && !b.tags.is_empty())
            .map(|b| b.entity_tag)
            .collect()
    };
    let triangles = on(etype::TRI3);
    let mut quads = on(etype::QUAD4);
    quads.retain(|s| !triangles.contains(s));
    quads.sort_unstable();
    quads.dedup();
    quads
}

/// What a surface holds: its nodes (tags, coordinate bits, parametric coordinate bits)
/// and its element blocks (type, tags, nodes), in file order.
type Held = (
    Vec<(u64, [u64; 3], Vec<u64>)>,
    Vec<(u32, Vec<u64>, Vec<u64>)>,
);

fn held(mesh: &Mesh, surface: i32) -> Held {
    let mut nodes = Vec::new();
    for b in mesh
        .node_blocks
        .iter()
        .filter(|b| b.entity_dim == 2 && b.entity_tag == surface)
    {
        for (i, (&tag, xyz)) in b.tags.iter().zip(&b.coords).enumerate() {
            let params = b
                .params
                .as_ref()
                .map(|p| p[2 * i..2 * i + 2].iter().map(|u| u.to_bits()).collect())
                .unwrap_or_default();
            nodes.push((tag, xyz.map(f64::to_bits), params));
        }
    }
    let elements = mesh
        .element_blocks
        .iter()
        .filter(|b| b.entity_dim == 2 && b.entity_tag == surface)
        .map(|b| (b.element_type, b.tags.clone(), b.nodes.clone()))
        .collect();
    (nodes, elements)
}

/// The coordinate bits of the nodes `mesh`'s elements on `surface` use, in the order the
/// elements use them (independent of numbering).
fn used_coordinates(mesh: &Mesh, surface: i32) -> Vec<[u64; 3]> {
    let index = mesh.node_index();
    let mut out = Vec::new();
    for b in mesh
        .element_blocks
        .iter()
        .filter(|b| b.entity_dim == 2 && b.entity_tag == surface)
    {
        for &n in &b.nodes {
            let r = index.get(n).expect("a node of an element");
            let b = &mesh.node_blocks[r.block as usize];
            out.push(b.coords[r.index as usize].map(f64::to_bits));
        }
    }
    out
}

fn read(path: &Path) -> Mesh {
    blossomquad::read(path).expect("read")
}

fn run(input: &Path, output: &Path, extra: &[&str]) -> String {
    let done = blossomquad()
        .arg(input)
        .arg("-o")
        .arg(output)
        .args(extra)
        .assert()
        .success();
    String::from_utf8_lossy(&done.get_output().stderr).into_owned()
}

#[test]
fn quad_surfaces_are_written_as_read() {
    let dir = tempfile::tempdir().expect("temp dir");
    let geo = repo_dir().join("tests/common/user_quads.geo");
    for variant in [Variant::Msh41Ascii, Variant::Msh22Ascii] {
        let input = dir
            .path()
            .join(format!("user_quads-{}.msh", variant.name()));
        let parametric = if variant.is_msh22() { 0.0 } else { 1.0 };
        generate_geo(&geo, &input, variant, 0.1, &[("parametric", parametric)]);
        let before = read(&input);
        let kept = quad_surfaces(&before);
        assert_eq!(
            kept.len(),
            2,
            "{}: the transfinite surface and the layer",
            variant.name()
        );
        if !variant.is_msh22() {
            let (nodes, _) = held(&before, kept[0]);
            assert!(
                nodes.iter().all(|n| n.2.len() == 2),
                "no parametric coordinates"
            );
        }

        // with --keep-tags: the same nodes (tags, coordinates and parametric coordinates bit
        // for bit; the text of a number may be a shorter one that reads back the same) and
        // the same quads, in the same order
        let out = dir.path().join("kept.msh");
        let summary = run(&input, &out, &["--keep-tags"]);
        assert!(!summary.contains("parity repair"), "{summary}");
        let after = read(&out);
        assert!(
            after
                .element_blocks
                .iter()
                .all(|b| b.entity_dim != 2 || b.element_type == etype::QUAD4),
            "triangles left"
        );
        for &s in &kept {
            assert!(
                held(&before, s) == held(&after, s),
                "{}: surface {s} changed",
                variant.name()
            );
        }
        // numbered 1..N (the default): the same coordinates in the same order
        let numbered = dir.path().join("numbered.msh");
        run(&input, &numbered, &[]);
        let numbered = read(&numbered);
        for &s in &kept {
            assert_eq!(used_coordinates(&before, s), used_coordinates(&numbered, s));
        }

        // --smooth-quads optimizes them too: the graded surface's nodes move
        let smoothed = dir.path().join("smoothed.msh");
        run(&input, &smoothed, &["--keep-tags", "--smooth-quads"]);
        let smoothed = read(&smoothed);
        assert!(
            kept.iter()
                .any(|&s| held(&before, s).0 != held(&smoothed, s).0),
            "{}: --smooth-quads moved no node",
            variant.name()
        );
    }
}
