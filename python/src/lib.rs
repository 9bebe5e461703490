//! `blossomquad._native`: the Rust side of the Python package. Each function takes plain
//! data (paths, JSON options, little-endian byte buffers) and runs the library's pipeline
//! with the GIL released; `blossomquad/__init__.py` wraps them in the documented API.

use std::path::PathBuf;
use std::sync::Arc;

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
/// taking `(stage, done, total)`) as the progress callback.
fn parse_options(json: &str, progress: Option<Py<PyAny>>) -> PyResult<blossomquad::Options> {
    let mut opts: blossomquad::Options = serde_json::from_str(json)
        .map_err(|e| PyValueError::new_err(format!("bad options: {e}")))?;
    if let Some(cb) = progress {
        opts.progress = Some(blossomquad::ProgressFn(Arc::new(
            move |p: blossomquad::Progress| {
                let stage = match p.stage {
                    blossomquad::Stage::Recombine => "recombine",
                    blossomquad::Stage::Refine => "refine",
                    blossomquad::Stage::Optimize => "optimize",
                    _ => "check",
                };
                Python::attach(|py| {
                    if let Err(e) = cb.call1(py, (stage, p.done, p.total)) {
                        e.write_unraisable(py, None);
                    }
                });
            },
        )));
    }
    Ok(opts)
}

fn report_json(report: &blossomquad::Report) -> PyResult<String> {
    serde_json::to_string(report).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// Runs the command line on `argv` (program name first); returns the exit code.
#[pyfunction]
fn cli(py: Python<'_>, argv: Vec<String>) -> u8 {
    py.detach(|| blossomquad::cli::run_args(argv))
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
        .detach(|| -> Result<blossomquad::Report, String> {
            let mut mesh = blossomquad::read(&input).map_err(|e| e.to_string())?;
            let report = blossomquad::quadrangulate(&mut mesh, &opts)
                .map_err(|e| format!("{}: {e}", input.display()))?;
            let format = blossomquad::msh::default_output_format(&mesh);
            blossomquad::write(&mesh, &output, format).map_err(|e| e.to_string())?;
            Ok(report)
        })
        .map_err(Error::new_err)?;
    report_json(&report)
}

/// Little-endian f64 values of `b` (length checked by the caller's shape).
fn f64s(b: &[u8]) -> Vec<f64> {
    b.chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
        .collect()
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

fn le_bytes<'py, T: Copy, const N: usize>(
    py: Python<'py>,
    v: &[T],
    f: impl Fn(T) -> [u8; N],
) -> Bound<'py, PyBytes> {
    let mut out = Vec::with_capacity(v.len() * N);
    for &x in v {
        out.extend_from_slice(&f(x));
    }
    PyBytes::new(py, &out)
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
    let opts = parse_options(options, progress)?;
    let p = f64s(points);
    let t = i64s(triangles);
    let f = i64s(fixed);
    let pts: Vec<[f64; 3]> = p.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let tris: Vec<[i64; 3]> = t.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let (out_pts, quads, report) = py
        .detach(|| -> Result<_, String> {
            let mut mesh =
                blossomquad::arrays::surface_mesh(&pts, &tris, &f).map_err(|e| e.to_string())?;
            let report = blossomquad::quadrangulate(&mut mesh, &opts).map_err(|e| e.to_string())?;
            let (p, q) = blossomquad::arrays::quads_of(&mesh, &pts);
            Ok((p, q, report))
        })
        .map_err(Error::new_err)?;
    let flat_p: Vec<f64> = out_pts.iter().flatten().copied().collect();
    let flat_q: Vec<u64> = quads.iter().flatten().copied().collect();
    Ok((
        le_bytes(py, &flat_p, f64::to_le_bytes),
        le_bytes(py, &flat_q, |x| (x as i64).to_le_bytes()),
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

/// Nodes and elements of the result, in the input's byte forms.
type ModelOut<'py> = (
    Vec<(i32, i32, Bound<'py, PyBytes>, Bound<'py, PyBytes>)>,
    Vec<(i32, i32, u32, Bound<'py, PyBytes>, Bound<'py, PyBytes>)>,
    String,
);

/// A whole model given as entity, node, element and periodic blocks (what Gmsh's API
/// returns); returns the result's node blocks and element blocks in the same byte forms,
/// and the report as JSON.
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
        let tags = u64s(tags.as_bytes());
        let c = f64s(coords.as_bytes());
        if c.len() != 3 * tags.len() {
            return Err(PyValueError::new_err(format!(
                "entity ({dim}, {tag}): {} node tags but {} coordinates",
                tags.len(),
                c.len()
            )));
        }
        mesh.node_blocks.push(NodeBlock {
            entity_dim: dim,
            entity_tag: tag,
            tags,
            coords: c.chunks_exact(3).map(|x| [x[0], x[1], x[2]]).collect(),
            params: None,
        });
    }
    for (dim, tag, element_type, tags, node_tags) in elements {
        let tags = u64s(tags.as_bytes());
        let nodes = u64s(node_tags.as_bytes());
        let per = blossomquad::mesh::element_node_count(element_type)
            .ok_or_else(|| PyValueError::new_err(format!("unknown element type {element_type}")))?;
        if nodes.len() != per * tags.len() {
            return Err(PyValueError::new_err(format!(
                "entity ({dim}, {tag}): {} elements of type {element_type} but {} node tags",
                tags.len(),
                nodes.len()
            )));
        }
        mesh.element_blocks.push(ElementBlock {
            entity_dim: dim,
            entity_tag: tag,
            element_type,
            tags,
            nodes,
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
    let report = py
        .detach(|| blossomquad::quadrangulate(&mut mesh, &opts))
        .map_err(|e| Error::new_err(e.to_string()))?;
    let nodes_out = mesh
        .node_blocks
        .iter()
        .map(|b| {
            let flat: Vec<f64> = b.coords.iter().flatten().copied().collect();
            (
                b.entity_dim,
                b.entity_tag,
                le_bytes(py, &b.tags, u64::to_le_bytes),
                le_bytes(py, &flat, f64::to_le_bytes),
            )
        })
        .collect();
    let elements_out = mesh
        .element_blocks
        .iter()
        .map(|b| {
            (
                b.entity_dim,
                b.entity_tag,
                b.element_type,
                le_bytes(py, &b.tags, u64::to_le_bytes),
                le_bytes(py, &b.nodes, u64::to_le_bytes),
            )
        })
        .collect();
    Ok((nodes_out, elements_out, report_json(&report)?))
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", blossomquad::VERSION)?;
    m.add("Error", m.py().get_type::<Error>())?;
    m.add_function(wrap_pyfunction!(cli, m)?)?;
    m.add_function(wrap_pyfunction!(recombine_file, m)?)?;
    m.add_function(wrap_pyfunction!(quadrangulate_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(recombine_model, m)?)?;
    Ok(())
}
