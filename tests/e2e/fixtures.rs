//! The fixtures in `geo/` are what they claim to be (needs Gmsh): they mesh
//! in all four MSH variants, parities are as designed, the OpenCASCADE solid
//! has many curved faces and several physical groups, and the shipped
//! `geo/rectangle.msh` is the rectangle fixture in MSH 4.1 ASCII.

use crate::common;

use common::{generate, geo_dir, gmsh_summary, test_size, Variant, FIXTURES};

/// Triangle counts per surface, from the summary's `elements 2 TAG 2 N ...` lines.
fn triangles_per_surface(summary: &str) -> Vec<(u64, u64)> {
    summary
        .lines()
        .filter_map(|line| {
            let f: Vec<&str> = line.split_whitespace().collect();
            match f.as_slice() {
                ["elements", "2", tag, "2", n, _] => Some((tag.parse().ok()?, n.parse().ok()?)),
                _ => None,
            }
        })
        .collect()
}

fn physical_groups(summary: &str, dim: &str) -> usize {
    summary
        .lines()
        .filter(|l| l.starts_with(&format!("physical {dim} ")))
        .count()
}

#[test]
fn every_fixture_meshes_in_every_variant() {
    let dir = tempfile::tempdir().expect("temp dir");
    for fixture in FIXTURES {
        let mut reference: Option<String> = None;
        for variant in Variant::ALL {
            let msh = generate(fixture, variant, dir.path(), test_size(fixture), &[]);
            let summary = gmsh_summary(
                &msh,
                &["--no-element-tags", "--no-classification", "--round"],
            );
            let tris: u64 = triangles_per_surface(&summary).iter().map(|t| t.1).sum();
            assert!(
                (500..=20_000).contains(&tris),
                "{fixture} {}: {tris} triangles at the test size",
                variant.name()
            );
            // The same mesh whatever the encoding (same tags, coordinates, elements).
            if !variant.is_msh22() {
                match &reference {
                    None => reference = Some(summary),
                    Some(r) => assert_eq!(r, &summary, "{fixture}: ASCII and binary 4.1 differ"),
                }
            }
        }
    }
}

#[test]
fn rectangle_and_square_hole_have_only_even_surfaces() {
    let dir = tempfile::tempdir().expect("temp dir");
    for fixture in ["rectangle", "square_hole"] {
        for size in [test_size(fixture), 0.7 * test_size(fixture)] {
            let msh = generate(fixture, Variant::Msh41Ascii, dir.path(), size, &[]);
            let summary = gmsh_summary(&msh, &[]);
            let tris = triangles_per_surface(&summary);
            assert_eq!(tris.len(), 1, "{fixture}: one surface");
            assert!(
                tris.iter().all(|&(_, n)| n % 2 == 0),
                "{fixture} at size {size}: odd surface {tris:?}"
            );
        }
    }
}

#[test]
fn even_curves_has_odd_surfaces() {
    let dir = tempfile::tempdir().expect("temp dir");
    for size in [1.0, 0.6] {
        let msh = generate("even_curves", Variant::Msh41Ascii, dir.path(), size, &[]);
        let tris = triangles_per_surface(&gmsh_summary(&msh, &[]));
        assert_eq!(tris.len(), 3);
        let odd: Vec<u64> = tris.iter().filter(|t| t.1 % 2 == 1).map(|t| t.0).collect();
        assert_eq!(odd, vec![2, 3], "size {size}: {tris:?}");
    }
}

#[test]
fn cad_solid_has_many_faces_and_physical_groups() {
    let dir = tempfile::tempdir().expect("temp dir");
    let msh = generate(
        "cad_solid",
        Variant::Msh41Ascii,
        dir.path(),
        test_size("cad_solid"),
        &[],
    );
    let summary = gmsh_summary(&msh, &[]);
    let tris = triangles_per_surface(&summary);
    assert!(tris.len() >= 11, "{} faces", tris.len());
    assert_eq!(physical_groups(&summary, "2"), 4, "{summary}");
    assert_eq!(physical_groups(&summary, "1"), 1, "{summary}");
    assert_eq!(physical_groups(&summary, "3"), 1, "{summary}");
    // Surface mesh only.
    assert!(
        !summary.lines().any(|l| l.starts_with("elements 3 ")),
        "{summary}"
    );
}

#[test]
fn shipped_rectangle_msh_is_the_rectangle_fixture() {
    let shipped = geo_dir().join("rectangle.msh");
    let bytes = std::fs::read(&shipped).expect("geo/rectangle.msh");
    assert!(bytes.len() <= 1 << 20, "{} bytes", bytes.len());
    assert!(
        bytes.starts_with(b"$MeshFormat\n4.1 0 8\n"),
        "not MSH 4.1 ASCII"
    );
    let dir = tempfile::tempdir().expect("temp dir");
    let fresh = generate("rectangle", Variant::Msh41Ascii, dir.path(), 1.0, &[]);
    assert_eq!(gmsh_summary(&shipped, &[]), gmsh_summary(&fresh, &[]));
    let tris = triangles_per_surface(&gmsh_summary(&shipped, &[]));
    assert_eq!(tris, vec![(1, 1792)]);
}
