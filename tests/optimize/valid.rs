//! The optimizer never turns a valid quad invalid: on the island
//! domain of `corpus/island_domain.py` (an ocean-like rectangle with 60 small polygonal islands,
//! meshed by Gmsh) and, as a property, on random planar domains with holes.
//!
//! "Invalid" here: a corner within 0.09° of straight or folded about the input's normal
//! (signed η at most 1e-3), or an edge of zero length. The matching itself may leave such
//! quads (a single triangle pair at a sharp island corner, which no node move can open):
//! the optimizer may keep those, as the same node sets, and create no other.

use crate::common;

use blossomquad::mesh::{etype, Mesh};
use blossomquad::optimize::synth::{self, Soup};
use blossomquad::optimize::{optimize, OptimizeOptions};
use blossomquad::quality::eta::{corner_eta, signed_angles};
use blossomquad::quality::eta_signed;
use blossomquad::recombine::{recombine, RecombineOptions};
use common::{blossomquad_run, check_mesh, python_exe, repo_dir, run};
use glam::DVec3;
use proptest::prelude::*;
use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Signed η below which (or at which) a quad counts as invalid.
const INVALID_ETA: f64 = 1e-3;

/// Every quad of `m`: its node tags and corner positions.
fn quads(m: &Mesh) -> Vec<([u64; 4], [DVec3; 4])> {
    let index = m.node_index();
    let mut out = Vec::new();
    for b in m
        .element_blocks
        .iter()
        .filter(|b| b.element_type == etype::QUAD4)
    {
        for e in 0..b.len() {
            let el = b.element(e);
            let tags = [el[0], el[1], el[2], el[3]];
            let p = tags.map(|t| {
                let r = index.get(t).expect("node exists");
                DVec3::from_array(m.node_blocks[r.block as usize].coords[r.index as usize])
            });
            out.push((tags, p));
        }
    }
    out
}

/// The average normal of the triangles of `m` (the orientation quads must keep).
fn triangle_normal(m: &Mesh) -> DVec3 {
    let index = m.node_index();
    let mut n = DVec3::ZERO;
    for b in m
        .element_blocks
        .iter()
        .filter(|b| b.element_type == etype::TRI3)
    {
        for e in 0..b.len() {
            let p = [0, 1, 2].map(|k| {
                let r = index.get(b.element(e)[k]).expect("node exists");
                DVec3::from_array(m.node_blocks[r.block as usize].coords[r.index as usize])
            });
            n += (p[1] - p[0]).cross(p[2] - p[0]);
        }
    }
    n.normalize()
}

fn sorted(t: [u64; 4]) -> [u64; 4] {
    let mut s = t;
    s.sort_unstable();
    s
}

/// The tags of the nodes on points and curves of `m` (they never move).
fn fixed_nodes(m: &Mesh) -> HashSet<u64> {
    m.node_blocks
        .iter()
        .filter(|b| b.entity_dim < 2)
        .flat_map(|b| b.tags.iter().copied())
        .collect()
}

/// What the quads of `m` are, about `normal`.
struct Validity {
    /// Sorted node sets of the invalid quads.
    bad: HashSet<[u64; 4]>,
    /// Per valid quad: its tags, its signed η and the best η its static corners (three
    /// fixed nodes, which no move changes) allow.
    good: Vec<([u64; 4], f64, f64)>,
    /// Shortest edge.
    shortest: f64,
}

fn validity(m: &Mesh, normal: DVec3) -> Validity {
    let fixed = fixed_nodes(m);
    let mut v = Validity {
        bad: HashSet::new(),
        good: Vec::new(),
        shortest: f64::INFINITY,
    };
    for (tags, p) in quads(m) {
        let e = eta_signed(&p, normal);
        let edge = (0..4)
            .map(|k| p[k].distance(p[(k + 1) % 4]))
            .fold(f64::INFINITY, f64::min);
        v.shortest = v.shortest.min(edge);
        if e <= INVALID_ETA || edge <= 0.0 {
            v.bad.insert(sorted(tags));
            continue;
        }
        let angles = signed_angles(&p, normal);
        let bound = (0..4)
            .filter(|&k| (0..3).all(|d| fixed.contains(&tags[(k + 3 + d) % 4])))
            .map(|k| corner_eta(angles[k]))
            .fold(1.0, f64::min);
        v.good.push((tags, e, bound));
    }
    v
}

/// The best worst η the input `m` allows: a wall node (on an edge of a single triangle)
/// whose triangles' angles sum to α < 90° never moves and keeps its wall edges, so every quad
/// corner there is at most α and every quad there has η ≤ α / 90° (eq. 3); 1 without such a
/// node.
fn input_bound(m: &Mesh) -> f64 {
    let index = m.node_index();
    let mut tris = Vec::new();
    for b in m
        .element_blocks
        .iter()
        .filter(|b| b.element_type == etype::TRI3)
    {
        for e in 0..b.len() {
            let el = b.element(e);
            tris.push([el[0], el[1], el[2]]);
        }
    }
    let at = |t: u64| {
        let r = index.get(t).expect("node exists");
        DVec3::from_array(m.node_blocks[r.block as usize].coords[r.index as usize])
    };
    let mut edges: std::collections::HashMap<(u64, u64), usize> = Default::default();
    for t in &tris {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let wall: HashSet<u64> = edges
        .iter()
        .filter(|(_, &n)| n == 1)
        .flat_map(|(&(a, b), _)| [a, b])
        .collect();
    let mut angle: std::collections::HashMap<u64, f64> = Default::default();
    for t in &tris {
        for k in 0..3 {
            if wall.contains(&t[k]) {
                let p = at(t[k]);
                let a = (at(t[(k + 1) % 3]) - p).angle_between(at(t[(k + 2) % 3]) - p);
                *angle.entry(t[k]).or_default() += a;
            }
        }
    }
    angle
        .values()
        .map(|&a| (a / std::f64::consts::FRAC_PI_2).min(1.0))
        .fold(1.0, f64::min)
}

/// Meshes the island domain (`seed`) at `size` into `dir`.
fn island_mesh(dir: &Path, size: f64, seed: u64) -> PathBuf {
    let out = dir.join(format!("islands-{seed}-{size}.msh"));
    let script = repo_dir().join("corpus/island_domain.py");
    let res = run(Command::new(python_exe()).arg(script).arg(&out).args([
        "--size",
        &size.to_string(),
        "--seed",
        &seed.to_string(),
    ]));
    assert!(
        res.status.success(),
        "island_domain.py failed: {}",
        String::from_utf8_lossy(&res.stderr)
    );
    out
}

/// Runs the tool on the island domain (`seed`) at `size` with and without optimization
/// and checks what the optimization must keep: no quad invalid that the matching did not
/// leave invalid, no edge of length 0, and η ≥ 0.2 on every quad that can reach it (its
/// static corners allow it and it shares no node with a quad the matching left invalid,
/// which pins its free nodes), and η_w ≥ 0.2 over those quads unless the input has a wall
/// corner narrower than 18°, where no quad can reach it (then η_w reaches that corner's
/// bound, [`input_bound`]). Returns (η_w, η̄) over the quads outside the matching's invalid
/// ones.
fn islands_stay_valid(size: f64, seed: u64) -> (f64, f64) {
    let dir = tempfile::tempdir().expect("temp dir");
    let input = island_mesh(dir.path(), size, seed);
    let matched = dir.path().join("matched.msh");
    let optimized = dir.path().join("optimized.msh");
    for (out, extra) in [(&matched, Some("--no-optimize")), (&optimized, None)] {
        let mut args = vec![
            input.as_os_str().to_owned(),
            "-o".into(),
            out.as_os_str().to_owned(),
            // the checks below compare the input and the outputs by node tag
            "--keep-tags".into(),
        ];
        args.extend(extra.map(Into::into));
        let (code, _, stderr) = blossomquad_run(args);
        assert_eq!(code, Some(0), "{stderr}");
    }
    let read = |p: &Path| blossomquad::msh::read_file(p).expect("readable output");
    let normal = triangle_normal(&read(&input));
    let before = validity(&read(&matched), normal);
    let after = validity(&read(&optimized), normal);
    let created: Vec<_> = after.bad.difference(&before.bad).collect();
    assert!(
        created.is_empty(),
        "seed {seed}: the optimizer made {} quad(s) invalid (nodes {created:?}); the \
         matching left {}",
        created.len(),
        before.bad.len()
    );
    assert!(after.shortest > 0.0, "seed {seed}: an edge of length 0");
    let pinned: HashSet<u64> = after.bad.iter().flatten().copied().collect();
    for &(tags, e, bound) in &after.good {
        if tags.iter().any(|t| pinned.contains(t)) {
            continue;
        }
        assert!(
            e >= 0.2_f64.min(bound - 1e-9),
            "seed {seed}: quad {tags:?} has eta {e} (its fixed corners allow {bound})"
        );
    }
    let worst = after.good.iter().map(|g| g.1).fold(f64::INFINITY, f64::min);
    let mean = after.good.iter().map(|g| g.1).sum::<f64>() / after.good.len() as f64;
    assert!(mean > 0.75, "seed {seed}: mean eta {mean}");
    // the goal: eta_w >= 0.2 wherever the input allows it (up to rounding of the angles)
    let allowed = 0.2_f64.min(input_bound(&read(&input)));
    assert!(
        worst >= allowed - 1e-6,
        "seed {seed}: eta_w {worst} below {allowed} (0.2, or the input's narrowest wall corner)"
    );
    for out in [&matched, &optimized] {
        let rep = check_mesh(&input, out, &[]);
        assert!(rep.ok, "{}", rep.report);
    }
    eprintln!(
        "islands seed {seed} at size {size}: {} quads, eta_w {worst:.3}, mean {mean:.3} \
         outside the {} quads the matching left invalid (kept as they were)",
        after.good.len() + after.bad.len(),
        after.bad.len()
    );
    (worst, mean)
}

/// ~1.3e4 triangles; on seed 1 the optimizer used to make a quad invalid (a straight
/// corner at an island wall node, η = 0 up to float noise). Seeds 1 and 2 used to end with
/// η_w 0.191 and 0.010: a wall node at 163° (179°) whose single quad held both its wall
/// edges; seed 2 has a 17.7° wall corner (η_w bound 0.196).
#[test]
fn the_island_domain_at_1e4_triangles_stays_valid_after_optimization() {
    for seed in [1, 2, 5, 11] {
        islands_stay_valid(1.0, seed);
    }
}

/// ~1.1e5 triangles (about 100 s in release for the three seeds, meshing and checker
/// included): `cargo test --release --test optimize valid -- --ignored`.
#[test]
#[ignore]
fn the_island_domain_at_1e5_triangles_stays_valid_after_optimization() {
    for seed in [1, 5, 11] {
        islands_stay_valid(0.31, seed);
    }
}

/// A Delaunay square of `n` × `n` points with the triangles inside `holes` (centre, radius)
/// removed: a planar domain whose hole walls are jagged (sharp corners, short walls).
fn square_with_holes(n: usize, jitter: f64, seed: u64, holes: &[(f64, f64, f64)]) -> Soup {
    let mut s = synth::delaunay_square(n, 1.0, jitter, seed);
    let pts = s.points.clone();
    s.faces.retain(|f| {
        let c = (pts[f[0]] + pts[f[1]] + pts[f[2]]) / 3.0;
        holes
            .iter()
            .all(|&(x, y, r)| (c.x - x).powi(2) + (c.y - y).powi(2) > r * r)
    });
    // keep only the used points, renumbered
    let mut map = vec![usize::MAX; s.points.len()];
    let mut points = Vec::new();
    for f in s.faces.iter_mut() {
        for v in f.iter_mut() {
            if map[*v] == usize::MAX {
                map[*v] = points.len();
                points.push(s.points[*v]);
            }
            *v = map[*v];
        }
    }
    s.points = points;
    s
}

/// Every quad after optimization keeps the orientation of the triangles and has η > 0,
/// unless the matching left it invalid as it is; no edge has length 0.
fn random_domain_stays_valid(
    n: usize,
    jitter: f64,
    seed: u64,
    holes: &[(f64, f64, f64)],
) -> Result<(), TestCaseError> {
    let tris = square_with_holes(n, jitter, seed, holes);
    let reference = synth::to_mesh(&tris);
    let mut m = reference.clone();
    if recombine(&mut m, &RecombineOptions::default()).is_err() {
        return Err(TestCaseError::reject("not recombined"));
    }
    let before = validity(&m, DVec3::Z);
    optimize(&mut m, &reference, &OptimizeOptions::default()).expect("optimize");
    let after = validity(&m, DVec3::Z);
    let created: Vec<_> = after.bad.difference(&before.bad).collect();
    prop_assert!(created.is_empty(), "quads made invalid: {:?}", created);
    prop_assert!(after.good.iter().all(|g| g.1 > 0.0));
    prop_assert!(after.shortest > 0.0, "an edge of length 0");
    blossomquad::optimize::check::check_surface_mesh(&m).map_err(TestCaseError::fail)?;
    Ok(())
}

/// Found by the property test below before the fix: a quad of a hole's wall turned invalid.
#[test]
fn regression_a_wall_quad_of_a_random_domain_stays_valid() {
    random_domain_stays_valid(
        19,
        0.23191592054667032,
        6487,
        &[(0.6393714266366828, 0.871001236949176, 0.1393332609942985)],
    )
    .expect("valid after optimization");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    /// On random planar domains with holes (jagged walls: sharp corners, short wall
    /// segments), the optimizer makes no quad invalid ([`random_domain_stays_valid`]).
    #[test]
    fn optimization_keeps_random_planar_domains_valid(
        n in 6usize..24,
        jitter in 0.0f64..0.45,
        seed in 1u64..10_000,
        holes in proptest::collection::vec((0.1f64..0.9, 0.1f64..0.9, 0.03f64..0.2), 0..8),
    ) {
        random_domain_stays_valid(n, jitter, seed, &holes)?;
    }
}
