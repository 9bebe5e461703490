//! `blossomquad._native`: the Rust side of the Python package. Each function takes plain
//! data (paths, JSON options, little-endian byte buffers) and runs the library's pipeline
//! with the GIL released; `blossomquad/__init__.py` wraps them in the documented API.

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use blossomquad::mesh::{ElementBlock, Entity, Mesh, NodeBlock, PeriodicLink, PhysicalName};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyBytes;

create_exception!(
    _native,
    Error,
    PyValueError,
    "A mesh blossomquad cannot read, recombine or write; the message is the command line's."
);

/// The options of `blossomquad::Options` from their JSON form, with `progress` (a callable
/// taking `(stage, done, total)`: the stage's name, as `blossomquad::Stage::name` gives it,
/// and `done` of `total > 0` units of it) as the progress callback.
fn parse_options(json: &str, progress: Option<Py<PyAny>>) -> PyResult<blossomquad::Options> {
    let mut opts: blossomquad::Options = serde_json::from_str(json)
        .map_err(|e| PyValueError::new_err(format!("bad options: {e}")))?;
    if let Some(cb) = progress {
        opts.progress = Some(blossomquad::ProgressFn(Arc::new(
            move |p: blossomquad::Progress| {
                Python::attach(|py| {
                    if let Err(e) = cb.call1(py, (p.stage.name(), p.done, p.total)) {
                        e.write_unraisable(py, None);
                    }
                });
            },
        )));
    }
    Ok(opts)
}

/// `e`'s message with, where an option is the way past it
/// ([`blossomquad::Error::option_past`]), that option as the Python functions name it.
fn message(e: &blossomquad::Error) -> String {
    match e.option_past() {
        Some("allow_invalid") => format!("{e} (pass allow_invalid=True to write the mesh anyway)"),
        Some(option) => format!("{e} ({option}=True)"),
        None => e.to_string(),
    }
}

fn report_json(report: &blossomquad::Report) -> PyResult<String> {
    serde_json::to_string(report).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// Runs the command line on `argv` (program name first); returns the exit code.
#[pyfunction]
fn cli(py: Python<'_>, argv: Vec<String>) -> u8 {
    py.detach(|| on_own_thread(|| blossomquad::cli::run_args(argv)))
}

/// The CLI's main job on files; returns the report as JSON.
#[pyfunction]
#[pyo3(signature = (input, output, options, progress=None))]
fn recombine_file(
    py: Python<'_>,
    input: PathBuf,
    output: PathBuf,
    options: &str,
    progress: Option<Py<PyAny>>,
) -> PyResult<String> {
    let opts = parse_options(options, progress)?;
    let same = match (input.canonicalize(), output.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    if same {
        return Err(Error::new_err(format!(
            "{}: the output would overwrite the input",
            output.display()
        )));
    }
    let report = py
        .detach(|| {
            on_own_thread(|| -> Result<blossomquad::Report, String> {
                let mut mesh = blossomquad::read(&input).map_err(|e| e.to_string())?;
                let report = blossomquad::quadrangulate(&mut mesh, &opts)
                    .map_err(|e| format!("{}: {}", input.display(), message(&e)))?;
                let format = blossomquad::msh::default_output_format(&mesh);
                blossomquad::write(&mesh, &output, format).map_err(|e| e.to_string())?;
                Ok(report)
            })
        })
        .map_err(Error::new_err)?;
    report_json(&report)
}

/// Little-endian i64 values of `b`.
fn i64s(b: &[u8]) -> Vec<i64> {
    b.chunks_exact(8)
        .map(|c| i64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
        .collect()
}

/// Little-endian u64 values of `b`.
fn u64s(b: &[u8]) -> Vec<u64> {
    b.chunks_exact(8)
        .map(|c| u64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
        .collect()
}

/// Little-endian points (three f64 each) of `b`, read straight into their final form.
fn xyz(b: &[u8]) -> Vec<[f64; 3]> {
    b.chunks_exact(24)
        .map(|c| {
            let x = |i: usize| f64::from_le_bytes(c[i..i + 8].try_into().unwrap_or([0; 8]));
            [x(0), x(8), x(16)]
        })
        .collect()
}

/// `v` as little-endian bytes, written straight into the Python object (one copy).
fn le_bytes<'py, T: Copy, const N: usize>(
    py: Python<'py>,
    v: &[T],
    f: impl Fn(T) -> [u8; N],
) -> PyResult<Bound<'py, PyBytes>> {
    PyBytes::new_with(py, v.len() * N, |out| {
        for (chunk, &x) in out.chunks_exact_mut(N).zip(v) {
            chunk.copy_from_slice(&f(x));
        }
        Ok(())
    })
}

/// One surface as arrays: `points` (n × 3 f64), `triangles` (m × 3 i64) and `fixed` (i64)
/// as little-endian bytes. Returns (points bytes, quads bytes (i64), report JSON).
#[pyfunction]
#[pyo3(signature = (points, triangles, fixed, options, progress=None))]
fn quadrangulate_arrays<'py>(
    py: Python<'py>,
    points: &[u8],
    triangles: &[u8],
    fixed: &[u8],
    options: &str,
    progress: Option<Py<PyAny>>,
) -> PyResult<(Bound<'py, PyBytes>, Bound<'py, PyBytes>, String)> {
    let mut opts = parse_options(options, progress)?;
    // the arrays are numbered by index (tag = index + 1): the tags must stay as they are
    opts.keep_tags = true;
    opts.tag_map = false;
    let pts = xyz(points);
    let t = i64s(triangles);
    let f = i64s(fixed);
    let tris: Vec<[i64; 3]> = t.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let (out_pts, quads, report) = py
        .detach(|| {
            on_own_thread(|| -> Result<_, String> {
                let mut mesh = blossomquad::arrays::surface_mesh(&pts, &tris, &f)
                    .map_err(|e| e.to_string())?;
                let report =
                    blossomquad::quadrangulate(&mut mesh, &opts).map_err(|e| message(&e))?;
                let (p, q) = blossomquad::arrays::quads_of(&mesh, &pts);
                Ok((p, q, report))
            })
        })
        .map_err(Error::new_err)?;
    let flat_p: Vec<f64> = out_pts.iter().flatten().copied().collect();
    let flat_q: Vec<u64> = quads.iter().flatten().copied().collect();
    Ok((
        le_bytes(py, &flat_p, f64::to_le_bytes)?,
        le_bytes(py, &flat_q, |x| (x as i64).to_le_bytes())?,
        report_json(&report)?,
    ))
}

/// An entity: (dim, tag, bbox[6], physical tags, bounding tags).
type EntityIn = (i32, i32, Vec<f64>, Vec<i32>, Vec<i32>);
/// Nodes of one entity: (dim, tag, node tags u64 bytes, coords f64 bytes).
type NodesIn<'py> = (i32, i32, Bound<'py, PyBytes>, Bound<'py, PyBytes>);
/// Elements of one entity and type: (dim, tag, type, element tags u64, node tags u64).
type ElementsIn<'py> = (i32, i32, u32, Bound<'py, PyBytes>, Bound<'py, PyBytes>);
/// A periodic link: (dim, tag, master tag, affine (16 or empty), slave nodes, master nodes).
type PeriodicIn<'py> = (
    i32,
    i32,
    i32,
    Vec<f64>,
    Bound<'py, PyBytes>,
    Bound<'py, PyBytes>,
);

/// Elements of one type on one entity, as returned: (type, element tags u64, node tags u64).
type ElementsOut<'py> = (u32, Bound<'py, PyBytes>, Bound<'py, PyBytes>);
/// One entity the result changes: (dim, tag, what, node tags u64, coords f64, elements).
/// `what` is `"elements"` when its nodes are unchanged (remove its elements, add these) and
/// `"mesh"` when its nodes changed too (clear its mesh, add these nodes and elements).
type ChangeOut<'py> = (
    i32,
    i32,
    &'static str,
    Bound<'py, PyBytes>,
    Bound<'py, PyBytes>,
    Vec<ElementsOut<'py>>,
);
/// The changed entities, the report as JSON and the seconds spent building the library's
/// mesh and comparing the result with it (the rest of the call is the pipeline).
type ModelOut<'py> = (Vec<ChangeOut<'py>>, String, f64);

/// What the result does to one entity of the model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Change {
    /// Same nodes (tags and coordinates, in order) and elements.
    Keep,
    /// Same nodes, other elements.
    Elements,
    /// Other nodes.
    Mesh,
}

/// The node blocks and element blocks of one entity, in block order.
type EntityBlocks<'a> = (Vec<&'a NodeBlock>, Vec<&'a ElementBlock>);

/// The blocks of `mesh` by entity `(dim, tag)`.
fn by_entity(mesh: &Mesh) -> BTreeMap<(i32, i32), EntityBlocks<'_>> {
    let mut out: BTreeMap<(i32, i32), EntityBlocks<'_>> = BTreeMap::new();
    for b in &mesh.node_blocks {
        out.entry((b.entity_dim, b.entity_tag))
            .or_default()
            .0
            .push(b);
    }
    for b in &mesh.element_blocks {
        out.entry((b.entity_dim, b.entity_tag))
            .or_default()
            .1
            .push(b);
    }
    out
}

/// The entities `after` changes relative to `before`, ascending by (dim, tag). Empty blocks
/// count as absent, so an entity whose only block was emptied is changed.
fn changes(before: &Mesh, after: &Mesh) -> Vec<((i32, i32), Change)> {
    let b = by_entity(before);
    let a = by_entity(after);
    let keys: BTreeSet<(i32, i32)> = b.keys().chain(a.keys()).copied().collect();
    let empty = (Vec::new(), Vec::new());
    let same_nodes = |x: &[&NodeBlock], y: &[&NodeBlock]| {
        let tags = |v: &[&NodeBlock]| v.iter().flat_map(|b| b.tags.iter()).copied().collect();
        let coords = |v: &[&NodeBlock]| v.iter().flat_map(|b| b.coords.iter()).copied().collect();
        let (tx, ty): (Vec<u64>, Vec<u64>) = (tags(x), tags(y));
        let (cx, cy): (Vec<[f64; 3]>, Vec<[f64; 3]>) = (coords(x), coords(y));
        tx == ty && cx == cy
    };
    let same_elements = |x: &[&ElementBlock], y: &[&ElementBlock]| {
        let x: Vec<_> = x.iter().filter(|b| !b.tags.is_empty()).collect();
        let y: Vec<_> = y.iter().filter(|b| !b.tags.is_empty()).collect();
        x.len() == y.len()
            && x.iter().zip(&y).all(|(p, q)| {
                p.element_type == q.element_type && p.tags == q.tags && p.nodes == q.nodes
            })
    };
    keys.into_iter()
        .map(|k| {
            let (bn, be) = b.get(&k).unwrap_or(&empty);
            let (an, ae) = a.get(&k).unwrap_or(&empty);
            let change = if !same_nodes(bn, an) {
                Change::Mesh
            } else if !same_elements(be, ae) {
                Change::Elements
            } else {
                Change::Keep
            };
            (k, change)
        })
        .collect()
}

/// Runs `work` on a thread of its own and waits for it (every entry point does). Speed:
/// the calling thread allocates from the C allocator's main arena, which Gmsh's meshing
/// leaves fragmented in the same process; a new thread gets an arena of its own (after
/// `gmsh.model.mesh.generate` at 1e6 triangles the pipeline ran 25-35% faster this way in
/// two alternating pairs on a loaded machine: see BENCHMARKS.md for how weak that is).
fn on_own_thread<T: Send>(work: impl FnOnce() -> T + Send) -> T {
    std::thread::scope(|s| match s.spawn(work).join() {
        Ok(v) => v,
        Err(panic) => std::panic::resume_unwind(panic),
    })
}

/// A whole model given as entity, node, element and periodic blocks (what Gmsh's API
/// returns); returns the entities the result changes with their new nodes and elements
/// (all of them for an entity whose nodes changed, the elements alone otherwise), the
/// report as JSON, and the seconds spent outside the pipeline. Entities the result leaves
/// as they were are not returned, so the caller leaves their mesh alone.
#[pyfunction]
#[pyo3(signature = (entities, names, nodes, elements, periodic, options, progress=None))]
#[allow(clippy::too_many_arguments)]
fn recombine_model<'py>(
    py: Python<'py>,
    entities: Vec<EntityIn>,
    names: Vec<(i32, i32, String)>,
    nodes: Vec<NodesIn<'py>>,
    elements: Vec<ElementsIn<'py>>,
    periodic: Vec<PeriodicIn<'py>>,
    options: &str,
    progress: Option<Py<PyAny>>,
) -> PyResult<ModelOut<'py>> {
    let t_in = Instant::now();
    let opts = parse_options(options, progress)?;
    let mut mesh = Mesh {
        has_entities_section: true,
        ..Default::default()
    };
    for (dim, tag, bbox, physical_tags, bounding) in entities {
        if !(0..=3).contains(&dim) {
            return Err(PyValueError::new_err(format!("entity dimension {dim}")));
        }
        let mut b = [0.0; 6];
        for (x, y) in b.iter_mut().zip(bbox) {
            *x = y;
        }
        mesh.entities[dim as usize].push(Entity {
            dim,
            tag,
            bbox: b,
            physical_tags,
            bounding,
        });
    }
    mesh.physical_names = names
        .into_iter()
        .map(|(dim, tag, name)| PhysicalName { dim, tag, name })
        .collect();
    for (dim, tag, tags, coords) in nodes {
        let (tags, coords) = (tags.as_bytes(), coords.as_bytes());
        if tags.len() % 8 != 0 || coords.len() != 3 * tags.len() {
            return Err(PyValueError::new_err(format!(
                "entity ({dim}, {tag}): {} bytes of node tags but {} bytes of coordinates",
                tags.len(),
                coords.len()
            )));
        }
        mesh.node_blocks.push(NodeBlock {
            entity_dim: dim,
            entity_tag: tag,
            tags: u64s(tags),
            coords: xyz(coords),
            params: None,
        });
    }
    for (dim, tag, element_type, tags, node_tags) in elements {
        let (tags, nodes) = (tags.as_bytes(), node_tags.as_bytes());
        let per = blossomquad::mesh::element_node_count(element_type)
            .ok_or_else(|| PyValueError::new_err(format!("unknown element type {element_type}")))?;
        if tags.len() % 8 != 0 || nodes.len() != per * tags.len() {
            return Err(PyValueError::new_err(format!(
                "entity ({dim}, {tag}): {} elements of type {element_type} but {} node tags",
                tags.len() / 8,
                nodes.len() / 8
            )));
        }
        mesh.element_blocks.push(ElementBlock {
            entity_dim: dim,
            entity_tag: tag,
            element_type,
            tags: u64s(tags),
            nodes: u64s(nodes),
            partitions: None,
        });
    }
    for (dim, tag, master_tag, affine, slave, master) in periodic {
        let s = u64s(slave.as_bytes());
        let m = u64s(master.as_bytes());
        mesh.periodic.push(PeriodicLink {
            dim,
            tag,
            master_tag,
            affine: (affine.len() == 16).then_some(affine),
            node_pairs: s.into_iter().zip(m).collect(),
        });
    }
    let mut outside = t_in.elapsed();
    let (report, changed, compare) = py
        .detach(|| -> Result<_, blossomquad::Error> {
            let t = Instant::now();
            let before = Mesh {
                node_blocks: mesh.node_blocks.clone(),
                element_blocks: mesh.element_blocks.clone(),
                ..Default::default()
            };
            let copy = t.elapsed();
            // on a thread of its own: see `on_own_thread`
            let report = on_own_thread(|| blossomquad::quadrangulate(&mut mesh, &opts))?;
            let t = Instant::now();
            let changed = changes(&before, &mesh);
            drop(before);
            Ok((report, changed, copy + t.elapsed()))
        })
        .map_err(|e| Error::new_err(message(&e)))?;
    let t_out = Instant::now();
    let after = by_entity(&mesh);
    let mut out = Vec::new();
    for (key, change) in changed {
        if change == Change::Keep {
            continue;
        }
        let (nodes, elements) = after.get(&key).cloned().unwrap_or_default();
        let (tags, coords): (Vec<u64>, Vec<f64>) = if change == Change::Mesh {
            (
                nodes.iter().flat_map(|b| b.tags.iter()).copied().collect(),
                nodes
                    .iter()
                    .flat_map(|b| b.coords.iter().flatten())
                    .copied()
                    .collect(),
            )
        } else {
            (Vec::new(), Vec::new())
        };
        let elements = elements
            .iter()
            .filter(|b| !b.tags.is_empty())
            .map(|b| {
                Ok((
                    b.element_type,
                    le_bytes(py, &b.tags, u64::to_le_bytes)?,
                    le_bytes(py, &b.nodes, u64::to_le_bytes)?,
                ))
            })
            .collect::<PyResult<Vec<_>>>()?;
        out.push((
            key.0,
            key.1,
            if change == Change::Mesh {
                "mesh"
            } else {
                "elements"
            },
            le_bytes(py, &tags, u64::to_le_bytes)?,
            le_bytes(py, &coords, f64::to_le_bytes)?,
            elements,
        ));
    }
    outside += compare + t_out.elapsed();
    Ok((out, report_json(&report)?, outside.as_secs_f64()))
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    blossomquad::set_memory_release(glibc::trim);
    m.add("__version__", blossomquad::VERSION)?;
    m.add("Error", m.py().get_type::<Error>())?;
    m.add_function(wrap_pyfunction!(cli, m)?)?;
    m.add_function(wrap_pyfunction!(recombine_file, m)?)?;
    m.add_function(wrap_pyfunction!(quadrangulate_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(recombine_model, m)?)?;
    Ok(())
}

/// glibc's heap trim, the library's memory-release hook (as the `blossomquad` program sets
/// it): the pipeline calls it between stages so that memory one stage freed does not stay
/// resident through the next. Unlike the program, the module leaves the arena settings
/// alone: the interpreter's threads exist before it is imported.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
mod glibc {
    extern "C" {
        /// Releases free heap memory to the system, keeping `pad` bytes; returns 1 if
        /// memory was released.
        fn malloc_trim(pad: usize) -> std::ffi::c_int;
    }

    /// Hands the heap's free pages back to the system.
    pub(super) fn trim() {
        // SAFETY: malloc_trim takes no pointer and only changes the allocator's own state,
        // under its own locks; any thread may call it at any time.
        unsafe {
            malloc_trim(0);
        }
    }
}
