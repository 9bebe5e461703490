//! The fallback's footprint on the coarse corpus models (`corpus/models.tsv`, MSH 4.1 as
//! `gmsh -2` writes it): a model of at least [`MIN_TRIANGLES`] input triangles ends with
//! at most [`MAX_QUADS_PER_TRIANGLE`] new quads per input triangle (0.5 when every
//! triangle pairs with a neighbour; a fallback that splits triangles into three quads
//! each raises it), and every model's worst quad η (eq. 3) is at least
//! min([`ETA_GOAL`], the input's wall-corner bound), less [`ETA_TOLERANCE`]. The bound: at every boundary node of
//! a surface (a node of an edge that only one of the surface's triangles has), the sum of
//! the surface's triangle angles there, divided by 90 degrees and capped at 1; the
//! smallest over the model's surfaces (a quad with a corner of that angle has η at most
//! the bound). `scripts/footprint.py` writes the same figures, and Gmsh's, into
//! BENCHMARKS.md. Runs the tool refuses are the robust test's business (its
//! `KNOWN_FAILING`) and are skipped here.

use crate::common;
use crate::robust::{known_failing, mesh_model, models, Model, VARIANTS};

use blossomquad::mesh::etype;
use blossomquad::Mesh;
use common::blossomquad_run;
use std::collections::HashMap;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// Input triangles from which the quads-per-triangle goal applies.
const MIN_TRIANGLES: usize = 500;
/// New quads per input triangle at most.
const MAX_QUADS_PER_TRIANGLE: f64 = 0.6;
/// The worst quad's η at least min(ETA_GOAL, wall-corner bound).
const ETA_GOAL: f64 = 0.2;
/// How far under that a worst quad still counts as at the bound (the tool's own margin,
/// `RAISE_MIN`): on a curved face a quad's corner at a sharp wall corner can fall a few
/// millionths under the sum of the triangles' angles there.
const ETA_TOLERANCE: f64 = 1e-3;

/// Models known to miss a footprint goal today, with their figures (input triangles,
/// new quads per input triangle, worst η, wall-corner bound), measured on the coarse
/// size in MSH 4.1. A listed model that meets the goals prints a line saying to remove
/// it; a model missing them that is not listed fails the test.
const EXCEEDING: &[(&str, &str)] = &[
    (
        "second_order_plate",
        "445 triangles, 0.48 quads/triangle, eta_w 0.097, bound 0.26",
    ),
    (
        "thin_annulus",
        "302 triangles, 0.50 quads/triangle, eta_w 0.103, bound 1.00",
    ),
];

/// One model's run: its footprint, None when refused as the robust test expects, or what
/// went wrong.
type Outcome = Result<Option<Footprint>, String>;

/// What one coarse model's run gives.
struct Footprint {
    triangles: usize,
    quads_per_triangle: f64,
    eta_w: f64,
    bound: f64,
}

impl Footprint {
    /// The goals this footprint misses, in words (empty when it meets them).
    fn misses(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.triangles >= MIN_TRIANGLES && self.quads_per_triangle > MAX_QUADS_PER_TRIANGLE {
            out.push(format!(
                "{:.2} new quads per input triangle > {MAX_QUADS_PER_TRIANGLE}",
                self.quads_per_triangle
            ));
        }
        let goal = ETA_GOAL.min(self.bound);
        if self.eta_w < goal - ETA_TOLERANCE {
            out.push(format!(
                "eta_w {:.3} < min({ETA_GOAL}, bound {:.2})",
                self.eta_w, self.bound
            ));
        }
        out
    }
}

impl std::fmt::Display for Footprint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} triangles, {:.2} quads/triangle, eta_w {:.3}, bound {:.2}",
            self.triangles, self.quads_per_triangle, self.eta_w, self.bound
        )
    }
}

fn read(path: &Path) -> Mesh {
    blossomquad::read(path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()))
}

/// The angle at `p` of the triangle `p q r`, in degrees.
fn corner_angle(p: [f64; 3], q: [f64; 3], r: [f64; 3]) -> f64 {
    let u = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
    let v = [r[0] - p[0], r[1] - p[1], r[2] - p[2]];
    let dot = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    let nu = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
    let nv = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if nu == 0.0 || nv == 0.0 {
        return 0.0;
    }
    (dot / (nu * nv)).clamp(-1.0, 1.0).acos().to_degrees()
}

/// The input's triangles (corner nodes) per surface entity.
fn triangles_by_surface(mesh: &Mesh) -> HashMap<i32, Vec<[u64; 3]>> {
    let mut out: HashMap<i32, Vec<[u64; 3]>> = HashMap::new();
    for b in &mesh.element_blocks {
        if b.entity_dim != 2 || !matches!(b.element_type, etype::TRI3 | etype::TRI6) {
            continue;
        }
        let tris = out.entry(b.entity_tag).or_default();
        for e in 0..b.len() {
            let n = b.element(e);
            tris.push([n[0], n[1], n[2]]);
        }
    }
    out
}

/// The wall-corner bound of `mesh` (see the module doc); 1 without a boundary node.
fn wall_corner_bound(mesh: &Mesh) -> f64 {
    let xyz: HashMap<u64, [f64; 3]> = mesh
        .node_blocks
        .iter()
        .flat_map(|b| b.tags.iter().copied().zip(b.coords.iter().copied()))
        .collect();
    let mut bound: f64 = 1.0;
    for tris in triangles_by_surface(mesh).values() {
        let mut edges: HashMap<(u64, u64), usize> = HashMap::new();
        let mut angle: HashMap<u64, f64> = HashMap::new();
        for t in tris {
            for k in 0..3 {
                let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
                *edges.entry((a.min(b), a.max(b))).or_default() += 1;
                let at = |n: u64| {
                    xyz.get(&n)
                        .copied()
                        .unwrap_or_else(|| panic!("node {n} missing"))
                };
                *angle.entry(a).or_default() += corner_angle(at(a), at(b), at(c));
            }
        }
        for ((a, b), count) in edges {
            if count != 2 {
                for n in [a, b] {
                    bound = bound.min(angle[&n] / 90.0);
                }
            }
        }
    }
    bound
}

/// Meshes one coarse model in MSH 4.1 and recombines it: Ok(Some(footprint)), Ok(None)
/// when the run is a KNOWN_FAILING one of the robust test, Err(description) otherwise.
fn run_one(model: &Model, dir: &Path) -> Outcome {
    run_at(&model.name, &model.coarse, dir)
}

/// [`run_one`] for the model `name` meshed at `size`.
fn run_at(name: &str, size: &str, dir: &Path) -> Outcome {
    let (variant, options) = VARIANTS[0];
    let input = dir.join(format!("{name}-{size}-{variant}.msh"));
    let output = dir.join(format!("{name}-{size}-{variant}.quads.msh"));
    mesh_model(name, size, options, &input)?;
    let (code, _, stderr) = blossomquad_run([input.as_os_str(), "-o".as_ref(), output.as_os_str()]);
    if code != Some(0) {
        return match known_failing(name, variant) {
            Some(_) => Ok(None),
            None => Err(format!("exit {code:?}: {}", stderr.trim())),
        };
    }
    let tri = read(&input);
    let quads = read(&output);
    let triangles: usize = triangles_by_surface(&tri).values().map(Vec::len).sum();
    let input_quads = blossomquad::quality::quad_etas(&tri).len();
    let etas = blossomquad::quality::quad_etas(&quads);
    if triangles == 0 {
        return Err("the input has no triangle".into());
    }
    if etas.is_empty() {
        return Err("the output has no quad".into());
    }
    Ok(Some(Footprint {
        triangles,
        quads_per_triangle: (etas.len() as f64 - input_quads as f64) / triangles as f64,
        eta_w: etas.iter().map(|&(_, e)| e).fold(f64::INFINITY, f64::min),
        bound: wall_corner_bound(&tri),
    }))
}

/// `second_order_plate` at the corpus's fine size (0.08): the first split try after the
/// fallback raises the worst quad from η 0.098 to 0.169 and leaves it under 0.2 on a face
/// whose first ring is all split; the second try, two rings around it, takes it to the
/// wall-corner bound (0.26), within the element-count rule.
#[test]
fn a_second_split_try_takes_the_worst_quad_to_the_goal() {
    let dir = tempfile::tempdir().expect("temp dir");
    let fp = run_at("second_order_plate", "0.08", dir.path())
        .unwrap_or_else(|e| panic!("{e}"))
        .expect("not refused");
    assert!(fp.triangles >= MIN_TRIANGLES, "{fp}");
    assert!(fp.misses().is_empty(), "{fp}: {:?}", fp.misses());
}

#[test]
fn coarse_corpus_models_meet_the_footprint_goals() {
    let models = models();
    for (name, _) in EXCEEDING {
        assert!(
            models.iter().any(|m| m.name == *name),
            "EXCEEDING names {name}, not in corpus/models.tsv"
        );
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<(String, Outcome)>> = Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..2 {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::SeqCst);
                let Some(model) = models.get(i) else {
                    break;
                };
                let result = run_one(model, dir.path());
                results
                    .lock()
                    .expect("results lock")
                    .push((model.name.clone(), result));
            });
        }
    });
    let mut results = results.into_inner().expect("results lock");
    results.sort_by(|a, b| a.0.cmp(&b.0));
    assert_eq!(results.len(), models.len(), "every model ran");
    let mut failures = Vec::new();
    let mut measured = 0;
    for (model, result) in &results {
        let listed = EXCEEDING
            .iter()
            .find(|(m, _)| m == model)
            .map(|(_, figures)| *figures);
        match result {
            Err(e) => failures.push(format!("{model}: {e}")),
            Ok(None) => println!("skipped (refused, KNOWN_FAILING of the robust test): {model}"),
            Ok(Some(fp)) => {
                measured += 1;
                let misses = fp.misses();
                match (misses.is_empty(), listed) {
                    (true, None) => {}
                    (true, Some(then)) => println!(
                        "EXCEEDING {model} now meets the footprint goals ({fp}; listed with {then}): remove it from the list"
                    ),
                    (false, Some(_)) => println!("known to exceed: {model}: {fp}: {}", misses.join("; ")),
                    (false, None) => failures.push(format!("{model}: {fp}: {}", misses.join("; "))),
                }
            }
        }
    }
    println!(
        "{} coarse models: {measured} measured, {} failing the footprint goals unlisted",
        results.len(),
        failures.len()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(measured >= 40, "only {measured} models measured");
}
