//! `blossomquad convert` on every fixture in all four MSH variants: Gmsh
//! reads back the same nodes, elements, entities and physical groups, and so
//! does our own reader (`info`); 4.1 -> 2.2 -> 4.1 keeps everything MSH 2.2
//! can express. Needs Gmsh.

use crate::common;

use common::{
    assert_variant, blossomquad, generate, gmsh_loads, gmsh_summary, test_size, Variant, FIXTURES,
};
use std::path::Path;

fn convert(input: &Path, output: &Path, args: &[&str]) {
    blossomquad()
        .arg("convert")
        .arg(input)
        .arg("-o")
        .arg(output)
        .args(args)
        .assert()
        .success();
}

/// `blossomquad info` without the lines that depend on the file's name or encoding.
fn info_counts(path: &Path) -> String {
    let out = blossomquad().arg("info").arg(path).assert().success();
    let stdout = String::from_utf8_lossy(&out.get_output().stdout).into_owned();
    let name = path.to_string_lossy().into_owned();
    stdout
        .lines()
        .filter(|l| {
            let lower = l.to_lowercase();
            !(l.contains(&name)
                || ["format", "msh", "ascii", "binary", "version"]
                    .iter()
                    .any(|w| lower.contains(w)))
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Summary flags comparing two files of these variants: element tags and node
/// classification are not part of what MSH 2.2 stores.
fn flags(a: Variant, b: Variant) -> Vec<&'static str> {
    if a.is_msh22() || b.is_msh22() {
        vec!["--no-element-tags", "--no-classification"]
    } else {
        vec![]
    }
}

fn convert_keeps_everything(fixture: &str) {
    let dir = tempfile::tempdir().expect("temp dir");
    for variant in Variant::ALL {
        let input = generate(fixture, variant, dir.path(), test_size(fixture), &[]);
        // Default: the input's version and encoding.
        let same = dir
            .path()
            .join(format!("{fixture}-{}-same.msh", variant.name()));
        convert(&input, &same, &[]);
        assert_variant(&same, variant);
        gmsh_loads(&same).unwrap_or_else(|e| panic!("{e}"));
        let f = flags(variant, variant);
        let f = if variant.is_msh22() { &f[..1] } else { &f[..] };
        assert_eq!(
            gmsh_summary(&input, f),
            gmsh_summary(&same, f),
            "{fixture} {}: Gmsh reads something else after convert",
            variant.name()
        );
        assert_eq!(
            info_counts(&input),
            info_counts(&same),
            "{fixture} {}: our reader disagrees",
            variant.name()
        );
        // Into every other variant.
        for target in Variant::ALL {
            let out = dir.path().join(format!(
                "{fixture}-{}-to-{}.msh",
                variant.name(),
                target.name()
            ));
            convert(&input, &out, &target.cli_args());
            assert_variant(&out, target);
            gmsh_loads(&out).unwrap_or_else(|e| panic!("{e}"));
            let f = flags(variant, target);
            let (mut a, mut b) = (gmsh_summary(&input, &f), gmsh_summary(&out, &f));
            if target.is_msh22() {
                a = expressible_in_msh22(&a);
                b = expressible_in_msh22(&b);
            }
            assert_eq!(a, b, "{fixture}: {} -> {}", variant.name(), target.name());
        }
    }
}

#[test]
fn convert_keeps_rectangle() {
    convert_keeps_everything("rectangle");
}

#[test]
fn convert_keeps_square_hole() {
    convert_keeps_everything("square_hole");
}

#[test]
fn convert_keeps_cad_solid() {
    convert_keeps_everything("cad_solid");
}

#[test]
fn convert_keeps_even_curves() {
    convert_keeps_everything("even_curves");
}

/// Drops physical groups none of whose entities has elements (MSH 2.2 derives
/// physical groups from elements, so it cannot store those).
fn expressible_in_msh22(summary: &str) -> String {
    let with_elements: Vec<(String, String)> = summary
        .lines()
        .filter_map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            (f.first() == Some(&"elements")).then(|| (f[1].to_string(), f[2].to_string()))
        })
        .collect();
    summary
        .lines()
        .filter(|l| {
            if !l.starts_with("physical ") {
                return true;
            }
            let dim = l.split_whitespace().nth(1).unwrap_or("");
            let ents = l.rsplit('[').next().unwrap_or("").trim_end_matches(']');
            ents.split(',')
                .map(str::trim)
                .any(|e| with_elements.iter().any(|(d, t)| d == dim && t == e))
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn round_trip_41_22_41_keeps_what_22_can_express() {
    let dir = tempfile::tempdir().expect("temp dir");
    for fixture in FIXTURES {
        for (v41, v22) in [
            (Variant::Msh41Ascii, Variant::Msh22Ascii),
            (Variant::Msh41Binary, Variant::Msh22Binary),
        ] {
            let input = generate(fixture, v41, dir.path(), test_size(fixture), &[]);
            let mid = dir.path().join(format!("{fixture}-{}-mid.msh", v22.name()));
            let back = dir
                .path()
                .join(format!("{fixture}-{}-back.msh", v41.name()));
            convert(&input, &mid, &v22.cli_args());
            convert(&mid, &back, &v41.cli_args());
            assert_variant(&back, v41);
            gmsh_loads(&back).unwrap_or_else(|e| panic!("{e}"));
            let f = ["--no-classification"];
            assert_eq!(
                expressible_in_msh22(&gmsh_summary(&input, &f)),
                expressible_in_msh22(&gmsh_summary(&back, &f)),
                "{fixture}: 4.1 -> 2.2 -> 4.1 ({})",
                v41.name()
            );
        }
    }
}
