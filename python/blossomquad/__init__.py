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
"""``progress(stage, done, total)``: ``done`` of ``total`` (> 0) units of ``stage``, one of
"topology", "graph", "matching", "refine", "optimize", "check", in that order (a fallback
round starts again from "topology"); within a stage ``done / total`` never decreases, and
each stage starts with ``done == 0`` and ends with ``done == total``. Calls are throttled (a few hundred per run)."""

# Python keyword -> field of the library's Options
_OPTIONS = {
    "parity": "parity",
    "cross_field": "cross_field_weight",
    "harmonic_cross_field": "harmonic_cross_field",
    "refine": "refine",
    "smooth": "smooth",
    "topology": "topology",
    "conformal_multigrid": "conformal_multigrid",
    "optimize": "optimize",
    "smooth_quads": "smooth_quads",
    "verify": "verify",
    "drop_volumes": "drop_volumes",
    "allow_invalid": "allow_invalid",
    "incomplete": "incomplete",
    "keep_tags": "keep_tags",
    "tag_map": "tag_map",
}


# options that only make sense when a file is written (Python keyword -> Options field)
_FILE_OPTIONS = {"quality_view": "quality_view"}


def _options(options: Dict[str, Any], file: bool = False) -> str:
    """The options as the JSON the Rust side reads; unknown names and bad values raise
    ``TypeError`` / ``ValueError`` here, in words. ``file``: the file options are known
    too."""
    known = dict(_OPTIONS, **_FILE_OPTIONS) if file else _OPTIONS
    out: Dict[str, Any] = {}
    for key, value in options.items():
        if key not in known:
            raise TypeError(
                f"unknown option {key!r} (known: {', '.join(sorted(known))}, progress)"
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
        out[known[key]] = value
    return json.dumps(out)


def recombine_file(
    input: str, output: str, *, progress: Optional[ProgressCallback] = None, **options: Any
) -> Dict[str, Any]:
    """Recombines the MSH file ``input`` into all-quad ``output`` (the command line's main
    job: the output keeps the input's MSH version and encoding, every physical group and
    entity; nodes and elements are numbered 1..N without gaps, as Gmsh numbers its files,
    keeping their order). Options as the command line's flags: ``parity`` ('repair' or
    'error'), ``cross_field`` (float), ``harmonic_cross_field``, ``refine`` (0-3), ``smooth``
    (sweeps), ``topology``, ``conformal_multigrid``, ``optimize``, ``smooth_quads`` (optimize the surfaces that hold
    no triangle in the input too; by default they are written as read), ``verify``, ``drop_volumes``, ``allow_invalid``,
    ``incomplete``, ``keep_tags`` (keep the input's node and element tags exactly, gaps and
    all), ``tag_map`` (the report's ``renumber["map"]`` gives ``nodes`` and ``elements``:
    ``[input tag, output tag]`` of every kept one), and ``quality_view`` (adds the "eta", "scaled jacobian" and "valence"
    views to the output, coloured by ``gmsh OUTPUT``). ``progress(stage, done, total)`` is called as the work advances (see
    ``ProgressCallback``). Returns the report
    (what was done per surface, times, log lines, and ``warnings``: a list of ``{"kind",
    "message"}``) as a dict. Nothing is written on error."""
    import os

    report = _native.recombine_file(
        os.fspath(input), os.fspath(output), _options(options, file=True), progress
    )
    return json.loads(report)


def quadrangulate(
    points: Any,
    triangles: Any,
    *,
    fixed: Any = None,
    return_index: bool = False,
    progress: Optional[ProgressCallback] = None,
    **options: Any,
) -> Tuple[Any, ...]:
    """Recombines one triangulated surface given as arrays into quads.

    ``points``: float array of shape (n, 3) (or (n, 2): z = 0); ``triangles``: integer array
    of shape (m, 3), indices into ``points`` (e.g. ``meshio.Mesh.points`` and
    ``mesh.cells_dict["triangle"]``). Boundary points never move; ``fixed`` (indices) pins
    more points. An odd number of triangles is repaired by splitting boundary edges, which
    adds points. Returns ``(points, quads)``: float64 (n', 3), only the points the quads
    use, the input's (at their optimized position) in the order of their index, then those
    the run added: the order of the command line's output numbering; and int64 (k, 4)
    quads of indices into them, oriented like the triangles. Input points no quad uses
    (unused in the input, or removed by the optimizer) are left out. With
    ``return_index=True``, returns ``(points, quads, index)``: ``index`` (int64, (n',)) is
    the input index of each returned point, -1 for an added one. Options as
    :func:`recombine_file`."""
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
    every = np.frombuffer(pts, dtype="<f8").reshape(-1, 3)
    cells = np.frombuffer(quads, dtype="<i8").reshape(-1, 4)
    # the native result keeps every input point at its index and appends the added ones
    # in tag order: the points in use, in that order, are the output numbering's
    used = np.unique(cells)
    renumber = np.full(len(every), -1, dtype="<i8")
    renumber[used] = np.arange(len(used), dtype="<i8")
    out = (every[used].copy(), renumber[cells])
    if return_index:
        return out + (np.where(used < len(p), used, -1).astype("<i8"),)
    return out


def recombine_gmsh(
    *, progress: Optional[ProgressCallback] = None, **options: Any
) -> Dict[str, Any]:
    """Recombines the mesh of the model currently open in the ``gmsh`` module (after
    ``gmsh.model.mesh.generate(2)`` or ``gmsh.open``), in place and with no file written:
    the triangles of every surface entity become quads, nodes added by parity repair go on
    their curves with their line elements, and nodes and elements are numbered 1..N without
    gaps in the order of their tags, as the file output is (so that
    ``dolfinx.io.gmsh.model_to_mesh`` reads the model; ``keep_tags=True`` keeps the input's
    tags exactly, gaps and all; ``tag_map=True`` returns the input -> output map in
    ``report["renumber"]["map"]``). Physical groups and entity tags are untouched, so ``gmsh.write``,
    ``gmsh.fltk.run()`` or a solver's Gmsh reader see the quads. Only the entities the
    result changes are written back (the recombined surfaces, curves split by parity repair,
    volumes whose elements ``drop_volumes`` removed); the others keep their mesh untouched,
    node parametric coordinates included. Options as :func:`recombine_file`; returns the
    report as a dict, with ``report["model"]``: ``rewritten`` (``[dim, tag, what]`` per
    entity written back, ``what`` being ``"mesh"``, ``"elements"`` or ``"all"``) and the
    seconds spent reading the model (``read_secs``), converting to and from the library's
    mesh (``convert_secs``) and writing the model (``write_secs``); the rest is in
    ``report["times"]``. A window of ``gmsh.fltk`` open on the model shows the quads at
    its next draw. On error the model is unchanged."""
    import time

    import gmsh
    import numpy as np

    t_read = time.perf_counter()
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
        # numpy arrays from Gmsh, handed over as bytes: no Python loop over nodes or elements
        ntags, coords, _ = model.mesh.getNodes(
            dim, tag, includeBoundary=False, returnParametricCoord=False
        )
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
    t_native = time.perf_counter()
    changed, report, convert = _native.recombine_model(
        entities, names, nodes, elements, periodic, _options(options), progress
    )
    t_write = time.perf_counter()
    rewritten = _write_back(gmsh.model.mesh, all_entities, changed, nodes, elements, periodic)
    if rewritten:
        # marks the mesh changed for Gmsh's graphics: the next draw (gmsh.graphics.draw(),
        # gmsh.fltk.run()) shows the quads instead of the triangles it had drawn
        model.setCurrent(model.getCurrent())
    out = json.loads(report)
    done = time.perf_counter()
    out["model"] = {
        "rewritten": rewritten,
        "read_secs": t_native - t_read,
        "convert_secs": convert,
        "write_secs": done - t_write,
    }
    return out


def _write_back(
    mesh: Any, all_entities: Any, changed: Any, nodes: Any, elements: Any, periodic: Any
) -> Any:
    """Writes the result into Gmsh's mesh: only the entities the result changes (the
    others keep their mesh as it was: nodes with their parametric coordinates, elements).
    ``"elements"``: same nodes, so the entity's elements alone are replaced; ``"mesh"``:
    nodes changed too (moved, removed or added), so the entity's mesh is cleared and added
    back (Gmsh has no call removing one node). Returns ``[dim, tag, what]`` per rewritten
    entity (``what`` is ``"all"`` for every entity when the whole mesh had to be
    replaced)."""
    import numpy as np

    u8 = lambda b: np.frombuffer(b, dtype="<u8")  # noqa: E731
    f8 = lambda b: np.frombuffer(b, dtype="<f8")  # noqa: E731
    # highest dimension first: volume elements dropped before the surface nodes they use go
    for dim, tag, what, _n, _c, _e in sorted(changed, key=lambda c: -c[0]):
        if what == "elements":
            mesh.removeElements(dim, tag)
    cleared = [(dim, tag) for dim, tag, what, _n, _c, _e in changed if what == "mesh"]
    # one at a time, highest dimension first: Gmsh keeps the mesh of a curve while a
    # surface's mesh still uses it
    for dim, tag in sorted(cleared, key=lambda e: -e[0]):
        mesh.clear([(dim, tag)])
    kept = [
        e for e in cleared if len(mesh.getNodes(*e, returnParametricCoord=False)[0])
    ]
    if kept:
        # Gmsh kept an entity's mesh (an unchanged entity's elements use it): the whole mesh
        # is replaced instead, the unchanged entities from what was read
        mesh.clear()
        new = {(d, t): (w, n, c, e) for d, t, w, n, c, e in changed}
        for dim, tag, ntags, coords in nodes:
            if new.get((dim, tag), ("",))[0] != "mesh":
                mesh.addNodes(dim, tag, u8(ntags), f8(coords))
        for (dim, tag), (what, ntags, coords, _e) in new.items():
            if what == "mesh" and len(ntags):
                mesh.addNodes(dim, tag, u8(ntags), f8(coords))
        for dim, tag, etype, etags, enodes in elements:
            if (dim, tag) not in new:
                mesh.addElementsByType(tag, etype, u8(etags), u8(enodes))
        for _d, tag, _w, _n, _c, blocks in changed:
            for etype, etags, enodes in blocks:
                mesh.addElementsByType(tag, etype, u8(etags), u8(enodes))
        for dim, tag, master, affine, _s, _m in periodic:
            mesh.setPeriodic(dim, [tag], [master], affine)
        return [[dim, tag, "all"] for dim, tag in all_entities]
    for dim, tag, what, ntags, coords, _e in changed:
        if what == "mesh" and len(ntags):
            mesh.addNodes(dim, tag, u8(ntags), f8(coords))
    for _d, tag, _w, _n, _c, blocks in changed:
        for etype, etags, enodes in blocks:
            mesh.addElementsByType(tag, etype, u8(etags), u8(enodes))
    # a cleared entity lost its periodic node pairs: Gmsh matches them again
    touched = set(cleared)
    for dim, tag, master, affine, _s, _m in periodic:
        if (dim, tag) in touched or (dim, master) in touched:
            mesh.setPeriodic(dim, [tag], [master], affine)
    return [[dim, tag, what] for dim, tag, what, _n, _c, _e in changed]
