"""blossomquad: turns triangle surface meshes into all-quadrilateral meshes with the
Blossom-Quad method (an exact minimum-cost perfect matching, then quad optimization).

Three ways in, one pipeline (the Rust library's ``quadrangulate``, the same as the
``blossomquad`` command):

- :func:`recombine_gmsh` works on the model open in the ``gmsh`` Python module, in the same
  process, with no file written;
- :func:`recombine_file` is the command line's main job on MSH files;
- :func:`quadrangulate` takes one surface as numpy arrays (points and triangles), e.g. from
  meshio.

Every function raises :class:`Error` (a ``ValueError``) with the command line's one-line
message when a mesh cannot be read, recombined or written, and ``ValueError`` for bad
arguments. The work runs with the GIL released.
"""

from __future__ import annotations

import json
from typing import Any, Callable, Dict, Optional, Tuple

from . import _native
from ._native import Error

__version__: str = _native.__version__

__all__ = ["Error", "__version__", "quadrangulate", "recombine_file", "recombine_gmsh"]

ProgressCallback = Callable[[str, int, int], None]

# Python keyword -> field of the library's Options
_OPTIONS = {
    "parity": "parity",
    "cross_field": "cross_field_weight",
    "harmonic_cross_field": "harmonic_cross_field",
    "refine": "refine",
    "smooth": "smooth",
    "topology": "topology",
    "optimize": "optimize",
    "verify": "verify",
    "drop_volumes": "drop_volumes",
    "allow_invalid": "allow_invalid",
    "incomplete": "incomplete",
}


def _options(options: Dict[str, Any]) -> str:
    """The options as the JSON the Rust side reads; unknown names and bad values raise
    ``TypeError`` / ``ValueError`` here, in words."""
    out: Dict[str, Any] = {}
    for key, value in options.items():
        if key not in _OPTIONS:
            raise TypeError(
                f"unknown option {key!r} (known: {', '.join(sorted(_OPTIONS))}, progress)"
            )
        if key == "parity":
            if value not in ("repair", "error"):
                raise ValueError(f"parity must be 'repair' or 'error', not {value!r}")
        elif key in ("refine",):
            if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value <= 3:
                raise ValueError(f"refine must be an integer 0..3, not {value!r}")
        elif key == "smooth":
            if value is not None and (
                not isinstance(value, int) or isinstance(value, bool) or value < 0
            ):
                raise ValueError(f"smooth must be None or an integer >= 0, not {value!r}")
        elif key == "cross_field":
            value = float(value)
            if not 0.0 <= value <= 5.0:
                raise ValueError(f"cross_field must be in [0, 5], not {value!r}")
        elif not isinstance(value, bool):
            raise ValueError(f"{key} must be True or False, not {value!r}")
        out[_OPTIONS[key]] = value
    return json.dumps(out)


def recombine_file(
    input: str, output: str, *, progress: Optional[ProgressCallback] = None, **options: Any
) -> Dict[str, Any]:
    """Recombines the MSH file ``input`` into all-quad ``output`` (the command line's main
    job: the output keeps the input's MSH version and encoding, every physical group, entity
    and node tag). Options as the command line's flags: ``parity`` ('repair' or 'error'),
    ``cross_field`` (float), ``harmonic_cross_field``, ``refine`` (0-3), ``smooth``
    (sweeps), ``topology``, ``optimize``, ``verify``, ``drop_volumes``, ``allow_invalid``.
    ``progress(stage, done, total)`` is called as the work advances. Returns the report
    (what was done per surface, times, log lines) as a dict. Nothing is written on error."""
    import os

    report = _native.recombine_file(
        os.fspath(input), os.fspath(output), _options(options), progress
    )
    return json.loads(report)


def quadrangulate(
    points: Any,
    triangles: Any,
    *,
    fixed: Any = None,
    progress: Optional[ProgressCallback] = None,
    **options: Any,
) -> Tuple[Any, Any]:
    """Recombines one triangulated surface given as arrays into quads.

    ``points``: float array of shape (n, 3) (or (n, 2): z = 0); ``triangles``: integer array
    of shape (m, 3), indices into ``points`` (e.g. ``meshio.Mesh.points`` and
    ``mesh.cells_dict["triangle"]``). Boundary points never move; ``fixed`` (indices) pins
    more points. An odd number of triangles is repaired by splitting boundary edges: the new
    points are appended. Returns ``(points, quads)``: float64 (n', 3) where every input
    point keeps its index (at its optimized position), and int64 (k, 4) quads oriented like
    the triangles. Options as :func:`recombine_file`."""
    import numpy as np

    p = np.asarray(points)
    if p.ndim != 2 or p.shape[1] not in (2, 3):
        raise ValueError(f"points must have shape (n, 3) or (n, 2), not {p.shape}")
    if not np.issubdtype(p.dtype, np.number):
        raise ValueError(f"points must be numbers, not {p.dtype}")
    p = p.astype("<f8")
    if p.shape[1] == 2:
        p = np.column_stack([p, np.zeros(len(p), dtype="<f8")])
    if not np.all(np.isfinite(p)):
        bad = int(np.argwhere(~np.isfinite(p))[0][0])
        raise ValueError(f"point {bad} has a coordinate that is not a finite number")
    t = np.asarray(triangles)
    if t.ndim != 2 or t.shape[1] != 3:
        raise ValueError(f"triangles must have shape (m, 3), not {t.shape}")
    if t.size and not np.issubdtype(t.dtype, np.integer):
        raise ValueError(f"triangles must be integer indices, not {t.dtype}")
    t = t.astype("<i8")
    f = np.zeros(0, dtype="<i8") if fixed is None else np.asarray(fixed).reshape(-1)
    if f.size and not np.issubdtype(f.dtype, np.integer):
        raise ValueError(f"fixed must be integer indices, not {f.dtype}")
    f = f.astype("<i8")
    pts, quads, _report = _native.quadrangulate_arrays(
        np.ascontiguousarray(p).tobytes(),
        np.ascontiguousarray(t).tobytes(),
        np.ascontiguousarray(f).tobytes(),
        _options(options),
        progress,
    )
    return (
        np.frombuffer(pts, dtype="<f8").reshape(-1, 3).copy(),
        np.frombuffer(quads, dtype="<i8").reshape(-1, 4).copy(),
    )


def recombine_gmsh(
    *, progress: Optional[ProgressCallback] = None, **options: Any
) -> Dict[str, Any]:
    """Recombines the mesh of the model currently open in the ``gmsh`` module (after
    ``gmsh.model.mesh.generate(2)`` or ``gmsh.open``), in place and with no file written:
    the triangles of every surface entity become quads with the kept element tags, moved
    nodes keep their tags, nodes added by parity repair go on their curves with their line
    elements. Physical groups and entity tags are untouched, so ``gmsh.write``,
    ``gmsh.fltk.run()`` or a solver's Gmsh reader see the quads. Options as
    :func:`recombine_file`; returns the report as a dict. On error the model is unchanged."""
    import gmsh
    import numpy as np

    model = gmsh.model
    all_entities = model.getEntities()
    entities = []
    for dim, tag in all_entities:
        try:
            bbox = list(model.getBoundingBox(dim, tag))
        except Exception:  # entities without a bounding box (discrete, empty)
            bbox = [0.0] * 6
        physical = [int(p) for p in model.getPhysicalGroupsForEntity(dim, tag)]
        bounding = []
        if dim > 0:
            bounding = [
                int(t)
                for _, t in model.getBoundary(
                    [(dim, tag)], combined=False, oriented=True, recursive=False
                )
            ]
        entities.append((dim, tag, bbox, physical, bounding))
    names = []
    for dim, tag in model.getPhysicalGroups():
        name = model.getPhysicalName(dim, tag)
        if name:
            names.append((dim, tag, name))
    nodes = []
    elements = []
    periodic = []
    for dim, tag in all_entities:
        ntags, coords, _ = model.mesh.getNodes(dim, tag, includeBoundary=False)
        if len(ntags):
            nodes.append(
                (
                    dim,
                    tag,
                    np.asarray(ntags, dtype="<u8").tobytes(),
                    np.asarray(coords, dtype="<f8").tobytes(),
                )
            )
        types, etags, enodes = model.mesh.getElements(dim, tag)
        for etype, et, en in zip(types, etags, enodes):
            elements.append(
                (
                    dim,
                    tag,
                    int(etype),
                    np.asarray(et, dtype="<u8").tobytes(),
                    np.asarray(en, dtype="<u8").tobytes(),
                )
            )
        if dim in (1, 2):
            master, slave_nodes, master_nodes, affine = model.mesh.getPeriodicNodes(dim, tag)
            if master != tag and len(slave_nodes):
                periodic.append(
                    (
                        dim,
                        tag,
                        int(master),
                        [float(x) for x in affine],
                        np.asarray(slave_nodes, dtype="<u8").tobytes(),
                        np.asarray(master_nodes, dtype="<u8").tobytes(),
                    )
                )
    out_nodes, out_elements, report = _native.recombine_model(
        entities, names, nodes, elements, periodic, _options(options), progress
    )
    # the result replaces the mesh: same node and element tags where kept, quads in place
    # of triangles, new nodes and line elements where parity repair or the fallback split
    # a curve
    model.mesh.clear()
    for dim, tag, ntags, coords in out_nodes:
        model.mesh.addNodes(
            dim,
            tag,
            np.frombuffer(ntags, dtype="<u8"),
            np.frombuffer(coords, dtype="<f8"),
        )
    for dim, tag, etype, etags, enodes in out_elements:
        model.mesh.addElementsByType(
            tag,
            etype,
            np.frombuffer(etags, dtype="<u8"),
            np.frombuffer(enodes, dtype="<u8"),
        )
    for dim, tag, master, affine, _s, _m in periodic:
        model.mesh.setPeriodic(dim, [tag], [master], affine)
    return json.loads(report)
