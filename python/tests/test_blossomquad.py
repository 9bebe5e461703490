"""The Python package: the command it installs, files, arrays and Gmsh's in-memory model.

Run with ``pytest python/tests`` after ``pip install ./python`` (scripts/test.sh does both).
"""

import os
import re
import subprocess
import threading

import numpy as np
import pytest

import blossomquad

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
RECTANGLE = os.path.join(REPO, "geo", "rectangle.msh")


def test_version_is_the_crate_version():
    with open(os.path.join(REPO, "Cargo.toml")) as f:
        version = re.search(r'^version = "([^"]+)"', f.read(), re.M).group(1)
    assert blossomquad.__version__ == version


def test_error_is_a_value_error():
    assert issubclass(blossomquad.Error, ValueError)


# --- the command ---------------------------------------------------------------------


def test_the_installed_command_runs_the_cli_with_its_exit_codes(tmp_path):
    out = tmp_path / "q.msh"
    ok = subprocess.run(["blossomquad", RECTANGLE, "-o", str(out), "--quiet"])
    assert ok.returncode == 0 and out.exists()
    bad = subprocess.run(
        ["blossomquad", str(tmp_path / "missing.msh"), "-o", str(tmp_path / "x.msh")],
        capture_output=True,
        text=True,
    )
    assert bad.returncode == 1
    assert bad.stderr.count("\n") == 1 and "missing.msh" in bad.stderr
    usage = subprocess.run(["blossomquad", "--bogus"], capture_output=True, text=True)
    assert usage.returncode == 2
    assert subprocess.run(["blossomquad", "--version"], capture_output=True).returncode == 0


# --- files ---------------------------------------------------------------------------


def test_recombine_file_writes_quads_and_returns_the_report(tmp_path):
    meshio = pytest.importorskip("meshio")
    out = tmp_path / "q.msh"
    calls = []
    report = blossomquad.recombine_file(
        RECTANGLE, out, progress=lambda s, d, t: calls.append((s, d, t))
    )
    assert report["recombine"]["surfaces"][0]["quads_out"] > 0
    assert "times" in report and report["invalid"] == []
    assert {c[0] for c in calls} >= {"graph", "matching", "optimize"}
    m = meshio.read(out)
    kinds = {c.type for c in m.cells}
    assert "quad" in kinds and "triangle" not in kinds


def test_progress_stages_arrive_in_order_with_growing_fractions(tmp_path):
    calls = []
    blossomquad.recombine_file(
        RECTANGLE, tmp_path / "q.msh", progress=lambda s, d, t: calls.append((s, d, t))
    )
    order = ["topology", "graph", "matching", "refine", "optimize", "check"]
    stages = [s for s, _, _ in calls]
    seen = [s for i, s in enumerate(stages) if i == 0 or stages[i - 1] != s]
    assert seen == ["topology", "graph", "matching", "optimize", "check"]
    assert [order.index(s) for s in stages] == sorted(order.index(s) for s in stages)
    for stage in seen:
        fractions = [d / t for s, d, t in calls if s == stage]
        assert all(0.0 <= f <= 1.0 for f in fractions), (stage, fractions)
        assert fractions == sorted(fractions), (stage, fractions)
        assert fractions[-1] == 1.0, (stage, fractions)
    # the matching stage reports between its ends
    assert any(s == "matching" and 0 < d < t for s, d, t in calls), calls


def test_recombine_file_quality_view_adds_one_value_per_quad(tmp_path):
    out = tmp_path / "q.msh"
    blossomquad.recombine_file(RECTANGLE, out, quality_view=True)
    gmsh.initialize(["-v", "0"])
    try:
        gmsh.open(str(out))
        quads = sum(len(t) for t in gmsh.model.mesh.getElements(2)[1])
        views = {
            gmsh.option.getString(f"View[{gmsh.view.getIndex(v)}].Name"): v
            for v in gmsh.view.getTags()
        }
        assert {"eta", "scaled jacobian", "valence"} <= set(views)
        kind, tags, data, _, _ = gmsh.view.getModelData(views["eta"], 0)
        assert kind == "ElementData" and len(tags) == quads
        assert all(0.0 < d[0] <= 1.0 for d in data)
    finally:
        gmsh.finalize()
    # the in-memory and array entry points write no file: the option is refused there
    with pytest.raises(TypeError, match="unknown option 'quality_view'"):
        blossomquad.quadrangulate(*grid(), quality_view=True)


def test_invalid_quads_are_refused_or_written_with_a_typed_warning(tmp_path):
    # a strip with a nearly flat boundary corner at node 2: no quad holding it is valid
    flat = tmp_path / "flat.msh"
    flat.write_text(
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 -1e-7 0\n3 2 0 0\n"
        "4 1 1 0\n$EndNodes\n$Elements\n2\n1 2 2 1 1 1 2 3\n2 2 2 1 1 1 3 4\n$EndElements\n")
    out = tmp_path / "out.msh"
    with pytest.raises(blossomquad.Error, match="allow_invalid=True") as e:
        blossomquad.recombine_file(flat, out)
    assert "--" not in str(e.value) and not out.exists()
    report = blossomquad.recombine_file(flat, out, allow_invalid=True)
    kinds = [w["kind"] for w in report["warnings"]]
    assert kinds == ["invalid_quads"], report["warnings"]
    assert report["warnings"][0]["message"].startswith("writing ")
    assert "invalid quad(s)" in report["warnings"][0]["message"]
    assert out.exists()


def test_recombine_file_errors_are_one_line_and_write_nothing(tmp_path):
    bad = tmp_path / "bad.msh"
    bad.write_text("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 2\n")
    out = tmp_path / "out.msh"
    with pytest.raises(blossomquad.Error) as e:
        blossomquad.recombine_file(bad, out)
    assert "bad.msh" in str(e.value) and "\n" not in str(e.value)
    assert not out.exists()
    with pytest.raises(blossomquad.Error, match="overwrite the input"):
        blossomquad.recombine_file(RECTANGLE, RECTANGLE)
    with pytest.raises(TypeError, match="unknown option"):
        blossomquad.recombine_file(RECTANGLE, out, smoothing=3)
    with pytest.raises(ValueError, match="parity"):
        blossomquad.recombine_file(RECTANGLE, out, parity="fix")


def test_a_file_without_surface_elements_is_refused_saying_why(tmp_path):
    # what gmsh -2 saves of a model whose physical groups are all volumes: no element
    empty = tmp_path / "volumes_only.msh"
    empty.write_text(
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n1\n3 1 \"solid\"\n"
        "$EndPhysicalNames\n$Nodes\n0\n$EndNodes\n$Elements\n0\n$EndElements\n")
    out = tmp_path / "out.msh"
    with pytest.raises(blossomquad.Error) as e:
        blossomquad.recombine_file(empty, out)
    message = str(e.value)
    assert "volumes_only.msh: nothing to recombine" in message, message
    assert "groups are all on volumes" in message and "save_all" in message, message
    assert not out.exists()


# --- arrays --------------------------------------------------------------------------


def grid(n=6, hole=True):
    """An n x n grid of unit squares as triangles, the middle square removed."""
    pts = np.array([[i, j, 0.0] for j in range(n + 1) for i in range(n + 1)])
    tris = []
    for j in range(n):
        for i in range(n):
            if hole and (i, j) == (n // 2, n // 2):
                continue
            a = j * (n + 1) + i
            tris += [[a, a + 1, a + n + 2], [a, a + n + 2, a + n + 1]]
    return pts, np.array(tris)


def check_quads(pts, quads, n_in):
    assert quads.dtype == np.int64 and quads.shape[1] == 4
    assert quads.min() >= 0 and quads.max() < len(pts)
    for q in quads:
        p = pts[q][:, :2]
        for k in range(4):
            a = p[(k + 1) % 4] - p[k]
            b = p[(k + 3) % 4] - p[k]
            # every corner strictly convex, counterclockwise like the triangles
            assert a[0] * b[1] - a[1] * b[0] > 1e-12


def test_quadrangulate_arrays_keeps_boundary_points_and_gives_valid_quads():
    pts, tris = grid()
    out_pts, quads, index = blossomquad.quadrangulate(pts, tris, return_index=True)
    assert len(out_pts) == len(index) <= len(pts)
    check_quads(out_pts, quads, len(pts))
    boundary = [i for i, p in enumerate(pts) if p[0] in (0, 6) or p[1] in (0, 6)]
    at = {int(k): i for i, k in enumerate(index)}
    assert all(b in at for b in boundary)
    assert np.array_equal(out_pts[[at[b] for b in boundary]], pts[boundary])


def test_an_odd_surface_gets_new_points_and_fixed_points_stay():
    pts, tris = grid()
    tris = tris[:-1]
    out_pts, quads, index = blossomquad.quadrangulate(
        pts[:, :2], tris, fixed=[8], return_index=True
    )
    assert (index == -1).any(), "parity repair adds a point"
    at = list(index).index(8)
    assert np.array_equal(out_pts[at], pts[8])
    check_quads(out_pts, quads, len(pts))


def test_quadrangulate_returns_only_the_points_its_quads_use_in_output_order():
    pts, tris = grid()
    tris = tris[:-1]  # odd: parity repair adds points
    # a point no triangle uses, between used ones
    stray = np.array([[50.0, 50.0, 0.0]])
    pts = np.vstack([pts[:10], stray, pts[10:]])
    tris = np.where(tris >= 10, tris + 1, tris)
    out_pts, quads, index = blossomquad.quadrangulate(pts, tris, return_index=True)
    # every point returned is used, and only those
    assert np.array_equal(np.unique(quads), np.arange(len(out_pts)))
    assert 10 not in index
    # the input's points in the order of their index, then the added ones (the command
    # line's output numbering: the rank of the tag)
    kept = index[index >= 0]
    assert np.all(np.diff(kept) > 0)
    assert np.all(index[len(kept):] == -1) and len(kept) < len(index)
    check_quads(out_pts, quads, len(pts))
    # without return_index: the same two arrays
    two = blossomquad.quadrangulate(pts, tris)
    assert len(two) == 2
    assert np.array_equal(two[0], out_pts) and np.array_equal(two[1], quads)


def test_meshio_data_works_directly(tmp_path):
    meshio = pytest.importorskip("meshio")
    m = meshio.read(RECTANGLE)
    pts, quads = blossomquad.quadrangulate(m.points, m.cells_dict["triangle"])
    assert len(quads) > 0
    # a VTU of these arrays holds no unused point
    assert np.array_equal(np.unique(quads), np.arange(len(pts)))
    check_quads(pts, quads, len(m.points))


@pytest.mark.parametrize(
    "points,triangles,message",
    [
        (np.zeros((4, 4)), [[0, 1, 2]], "shape"),
        (np.zeros((4, 3)), [[0, 1]], "shape"),
        (np.zeros((4, 3)), [[0.0, 1.0, 2.0]], "integer"),
        (np.array([[0, 0, 0], [1, 0, 0], [0, np.nan, 0]]), [[0, 1, 2]], "finite"),
        (np.array([["a", "b", "c"]]), [[0, 0, 0]], "numbers"),
        (np.eye(3), [[0, 1, 7]], "refers to point 7"),
        (np.eye(3), [[0, 1, 1]], "twice"),
    ],
)
def test_bad_arrays_raise_value_error_in_words(points, triangles, message):
    with pytest.raises(ValueError, match=message):
        blossomquad.quadrangulate(points, triangles)


def test_the_gil_is_released_while_the_work_runs():
    pts, tris = grid(n=120, hole=False)
    done = threading.Event()
    ticks = 0

    def work():
        blossomquad.quadrangulate(pts, tris)
        done.set()

    t = threading.Thread(target=work)
    t.start()
    while not done.is_set():
        ticks += 1
        done.wait(0.001)
    t.join()
    assert ticks > 20, "the main thread could not run while the mesh was recombined"


# --- Gmsh's in-memory model ----------------------------------------------------------

gmsh = pytest.importorskip("gmsh") if os.environ.get("BLOSSOMQUAD_ALLOW_NO_GMSH") else None
if gmsh is None:
    import gmsh  # CI installs it: a missing module fails loudly


@pytest.fixture
def model():
    gmsh.initialize(["-v", "0"])
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("plate")
    yield gmsh.model
    gmsh.finalize()


def plate_with_hole(size):
    occ = gmsh.model.occ
    box = occ.addRectangle(0, 0, 0, 2, 1)
    hole = occ.addDisk(1, 0.5, 0, 0.2, 0.2)
    occ.cut([(2, box)], [(2, hole)])
    occ.synchronize()
    gmsh.model.addPhysicalGroup(2, [1], 7, name="plate")
    curves = [t for _, t in gmsh.model.getEntities(1)]
    gmsh.model.addPhysicalGroup(1, curves, 8, name="edges")
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.model.mesh.generate(2)


def element_counts(dim):
    counts = {}
    for _, tag in gmsh.model.getEntities(dim):
        types, tags, _ = gmsh.model.mesh.getElements(dim, tag)
        for t, et in zip(types, tags):
            counts[int(t)] = counts.get(int(t), 0) + len(et)
    return counts


def assert_numbered_1_to_n():
    """The open model's node tags are 1..N and its element tags 1..M."""
    tags = np.sort(gmsh.model.mesh.getNodes()[0])
    assert np.array_equal(tags, np.arange(1, len(tags) + 1)), (tags[:3], tags[-3:], len(tags))
    etags = np.sort(np.concatenate([t for t in gmsh.model.mesh.getElements()[1]]))
    assert np.array_equal(etags, np.arange(1, len(etags) + 1)), (etags[-3:], len(etags))


def test_recombine_gmsh_numbers_the_model_1_to_n_and_keeps_curve_nodes(model):
    plate_with_hole(0.1)
    curves = {c: gmsh.model.mesh.getNodes(1, c, returnParametricCoord=True)
              for _, c in gmsh.model.getEntities(1)}
    report = blossomquad.recombine_gmsh()
    assert_numbered_1_to_n()
    split = {s["curve"] for s in report["recombine"]["parity_splits"]}
    mesh_rewritten = {(d, t) for d, t, what in report["model"]["rewritten"] if what == "mesh"}
    for c, (ntags, _, params) in curves.items():
        if c in split:
            continue
        # Gmsh numbers curve nodes before surface nodes: they keep tags and parameters
        assert (1, c) not in mesh_rewritten, c
        n, _, p = gmsh.model.mesh.getNodes(1, c, returnParametricCoord=True)
        assert (n.tolist(), p.tolist()) == (ntags.tolist(), params.tolist()), c


def test_recombine_gmsh_keep_tags_keeps_the_model_tags_gaps_and_all(model):
    plate_with_hole(0.1)
    nodes_before = set(gmsh.model.mesh.getNodes()[0].tolist())
    tri_tags = set(gmsh.model.mesh.getElements(2, 1)[1][0].tolist())
    report = blossomquad.recombine_gmsh(keep_tags=True)
    assert report["renumber"]["map"] is None
    tags = gmsh.model.mesh.getNodes()[0].tolist()
    assert report["optimize"]["nodes_removed"] > 0
    # removed nodes leave gaps; kept nodes keep their tags, new ones come above
    assert max(tags) > len(tags)
    assert all(t in nodes_before or t > max(nodes_before) for t in tags)
    assert set(gmsh.model.mesh.getElements(2, 1)[1][0].tolist()) <= tri_tags


def test_recombine_gmsh_turns_the_open_model_into_quads(model, tmp_path):
    plate_with_hole(0.1)
    curve_nodes_before = {}
    for _, c in gmsh.model.getEntities(1):
        tags, coords, _ = gmsh.model.mesh.getNodes(1, c, includeBoundary=True)
        curve_nodes_before.update(zip(tags, coords.reshape(-1, 3).tolist()))
    tri_tags = set(gmsh.model.mesh.getElements(2, 1)[1][0])
    report = blossomquad.recombine_gmsh(tag_map=True)
    assert report["invalid"] == []
    counts = element_counts(2)
    assert 2 not in counts and counts.get(3, 0) > 0, counts
    nodes, elements = report["renumber"]["map"]["nodes"], report["renumber"]["map"]["elements"]
    back = {b: a for a, b in elements}
    quad_tags = set(gmsh.model.mesh.getElements(2, 1)[1][0])
    assert {back[t] for t in quad_tags} <= tri_tags, "quads take tags of the triangles they replace"
    # curve nodes kept, unmoved
    new = dict(nodes)
    for tag, xyz in curve_nodes_before.items():
        coord, _, _, _ = gmsh.model.mesh.getNode(new[tag])
        assert np.allclose(coord, xyz)
    assert_numbered_1_to_n()
    # physical groups survive, and every element is valid for a solver
    assert gmsh.model.getPhysicalName(2, 7) == "plate"
    assert set(gmsh.model.getPhysicalGroups()) == {(2, 7), (1, 8)}
    types, tags, _ = gmsh.model.mesh.getElements(2, 1)
    sj = gmsh.model.mesh.getElementQualities(tags[0], "minSJ")
    assert min(sj) > 0
    # what gmsh writes reads back with the quads
    out = str(tmp_path / "plate.msh")
    gmsh.write(out)
    gmsh.clear()
    gmsh.open(out)
    assert 2 not in element_counts(2)


def test_recombine_gmsh_leaves_the_entities_it_does_not_change_alone(model):
    plate_with_hole(0.1)
    curves = {}
    for _, c in gmsh.model.getEntities(1):
        ntags, _, params = gmsh.model.mesh.getNodes(1, c, returnParametricCoord=True)
        _, etags, enodes = gmsh.model.mesh.getElements(1, c)
        assert len(params) == len(ntags) > 0, "Gmsh gives curve nodes their parameter"
        curves[c] = (ntags.tolist(), params.tolist(), etags[0].tolist(), enodes[0].tolist())
    # the input's tags kept: untouched entities are exactly as they were (by default their
    # element tags may move to close the gaps, their nodes staying; see the numbering test)
    report = blossomquad.recombine_gmsh(keep_tags=True)
    # the surface is written back, and the curves parity repair split; the other curves
    # keep their nodes with their parameters (which adding nodes back would lose) and their
    # line elements
    split = {s["curve"] for s in report["recombine"]["parity_splits"]}
    assert report["model"]["rewritten"] == [[1, c, "mesh"] for c in sorted(split)] + [
        [2, 1, "mesh"]
    ]
    assert len(split) < len(curves)
    for c, (ntags, params, etags, enodes) in curves.items():
        if c in split:
            continue
        n, _, p = gmsh.model.mesh.getNodes(1, c, returnParametricCoord=True)
        _, et, en = gmsh.model.mesh.getElements(1, c)
        assert (n.tolist(), p.tolist()) == (ntags, params), c
        assert (et[0].tolist(), en[0].tolist()) == (etags, enodes), c
    times = report["model"]
    assert all(times[k] >= 0 for k in ("read_secs", "convert_secs", "write_secs"))
    assert 2 not in element_counts(2)


def test_recombine_gmsh_leaves_the_surfaces_meshed_with_quads_alone(model):
    # a graded transfinite surface (1) and an extruded boundary layer (8), both recombined
    # by Gmsh, beside a triangle surface (2)
    geo = os.path.join(REPO, "tests", "common", "user_quads.geo")
    for smooth_quads in (False, True):
        gmsh.clear()
        gmsh.open(geo)
        gmsh.model.mesh.generate(2)
        before = gmsh.model.mesh.getNodes(2, 1, returnParametricCoord=True)
        report = blossomquad.recombine_gmsh(keep_tags=True, smooth_quads=smooth_quads)
        surfaces = [t for d, t, _ in report["model"]["rewritten"] if d == 2]
        after = gmsh.model.mesh.getNodes(2, 1, returnParametricCoord=True)
        same = all(np.array_equal(a, b) for a, b in zip(before, after))
        if smooth_quads:
            assert 1 in surfaces and not same
        else:
            assert surfaces == [2] and same
        assert 2 not in element_counts(2)


def test_recombine_gmsh_replaces_the_whole_mesh_when_gmsh_keeps_an_entity(
    model, monkeypatch
):
    # Gmsh refuses to clear an entity whose nodes elements of another entity use; whatever
    # the reason, the model must not end up with the nodes twice: the whole mesh is replaced
    plate_with_hole(0.1)
    nodes_before = len(gmsh.model.mesh.getNodes()[0])
    clear = gmsh.model.mesh.clear
    monkeypatch.setattr(
        gmsh.model.mesh, "clear", lambda dimTags=[]: clear(dimTags) if not dimTags else None
    )
    report = blossomquad.recombine_gmsh()
    assert report["model"]["rewritten"] == [[d, t, "all"] for d, t in gmsh.model.getEntities()]
    tags, coords, _ = gmsh.model.mesh.getNodes()
    assert len(tags) == len(set(tags.tolist()))
    assert len(np.unique(coords.reshape(-1, 3), axis=0)) == len(tags)
    removed = report["optimize"]["nodes_removed"]
    added = len(report["recombine"]["parity_splits"])
    assert len(tags) == nodes_before - removed + added
    assert 2 not in element_counts(2)
    _, etags, _ = gmsh.model.mesh.getElements(2, 1)
    assert min(gmsh.model.mesh.getElementQualities(etags[0], "minSJ")) > 0


def test_recombine_gmsh_repairs_parity_on_the_model_curves(model):
    occ = gmsh.model.occ
    occ.addRectangle(0, 0, 0, 1, 1)
    occ.synchronize()
    # 3 + 3 + 3 + 4 = 13 boundary segments: an odd number of triangles
    for i, (_, c) in enumerate(gmsh.model.getEntities(1)):
        gmsh.model.mesh.setTransfiniteCurve(c, 5 if i == 0 else 4)
    gmsh.model.mesh.generate(2)
    n_tris = sum(len(t) for t in gmsh.model.mesh.getElements(2, 1)[1])
    assert n_tris % 2 == 1
    max_node = gmsh.model.mesh.getMaxNodeTag()
    lines_before = element_counts(1).get(1, 0)
    report = blossomquad.recombine_gmsh(keep_tags=True)
    assert report["recombine"]["parity_splits"], report["log"]
    assert 2 not in element_counts(2)
    assert gmsh.model.mesh.getMaxNodeTag() > max_node
    assert element_counts(1).get(1, 0) > lines_before, "a split curve gets its new line"
    types, tags, _ = gmsh.model.mesh.getElements(2, 1)
    assert min(gmsh.model.mesh.getElementQualities(tags[0], "minSJ")) > 0


def test_recombine_gmsh_errors_leave_the_model_unchanged(model):
    gmsh.model.occ.addBox(0, 0, 0, 1, 1, 1)
    gmsh.model.occ.synchronize()
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.5)
    gmsh.model.mesh.generate(3)
    before = element_counts(3)
    with pytest.raises(blossomquad.Error, match="volume") as e:
        blossomquad.recombine_gmsh()
    # the way past it, named as the Python functions name it (not the command line's flag)
    assert "drop_volumes=True" in str(e.value) and "--" not in str(e.value), str(e.value)
    assert element_counts(3) == before
    volume_nodes = gmsh.model.mesh.getNodes(3, 1)[0].tolist()
    report = blossomquad.recombine_gmsh(drop_volumes=True, keep_tags=True)
    assert 2 not in element_counts(2)
    # the tetrahedra go, as with --drop-volumes; the volume's nodes stay, as in the file
    assert element_counts(3) == {}
    assert [3, 1, "elements"] in report["model"]["rewritten"]
    assert gmsh.model.mesh.getNodes(3, 1)[0].tolist() == volume_nodes
    for _, s in gmsh.model.getEntities(2):
        _, tags, _ = gmsh.model.mesh.getElements(2, s)
        assert min(gmsh.model.mesh.getElementQualities(tags[0], "minSJ")) > 0, s


def test_recombine_gmsh_keeps_periodic_curves_periodic(model):
    gmsh.model.occ.addRectangle(0, 0, 0, 1, 1)
    gmsh.model.occ.synchronize()
    left = gmsh.model.getEntitiesInBoundingBox(-0.1, -0.1, -0.1, 0.1, 1.1, 0.1, 1)[0][1]
    right = gmsh.model.getEntitiesInBoundingBox(0.9, -0.1, -0.1, 1.1, 1.1, 0.1, 1)[0][1]
    shift = [1, 0, 0, 1, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]
    gmsh.model.mesh.setPeriodic(1, [right], [left], shift)
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.1)
    gmsh.model.mesh.generate(2)
    before = gmsh.model.mesh.getPeriodicNodes(1, right)
    blossomquad.recombine_gmsh()
    master, slaves, masters, affine = gmsh.model.mesh.getPeriodicNodes(1, right)
    assert master == left and len(slaves) == len(before[1]) > 0
    for s, m in zip(slaves, masters):
        xs = gmsh.model.mesh.getNode(s)[0]
        xm = gmsh.model.mesh.getNode(m)[0]
        assert np.allclose(xs, xm + [1, 0, 0])
    assert 2 not in element_counts(2)


@pytest.mark.parametrize(
    "geo,size",
    [("rectangle", 1.0), ("square_hole", 2.7), ("cad_solid", 2.0), ("even_curves", 2.0)],
)
def test_recombine_gmsh_on_the_geo_fixtures(model, tmp_path, geo, size):
    meshio = pytest.importorskip("meshio")
    gmsh.onelab.setNumber("Parameters/size", [size])
    gmsh.open(os.path.join(REPO, "geo", f"{geo}.geo"))
    gmsh.model.mesh.generate(2)
    groups = sorted(gmsh.model.getPhysicalGroups())
    names = {g: gmsh.model.getPhysicalName(*g) for g in groups}
    boundary = {}
    for dim in (0, 1):
        for _, tag in gmsh.model.getEntities(dim):
            ntags, coords, _ = gmsh.model.mesh.getNodes(dim, tag)
            boundary.update(zip(ntags, coords.reshape(-1, 3).tolist()))
    report = blossomquad.recombine_gmsh(tag_map=True)
    assert report["invalid"] == []
    counts = element_counts(2)
    assert 2 not in counts and counts.get(3, 0) > 0, counts
    assert sorted(gmsh.model.getPhysicalGroups()) == groups
    assert {g: gmsh.model.getPhysicalName(*g) for g in groups} == names
    new = dict(report["renumber"]["map"]["nodes"])
    for tag, xyz in boundary.items():
        assert np.allclose(gmsh.model.mesh.getNode(new[tag])[0], xyz), tag
    assert_numbered_1_to_n()
    for _, s in gmsh.model.getEntities(2):
        _, tags, _ = gmsh.model.mesh.getElements(2, s)
        assert min(gmsh.model.mesh.getElementQualities(tags[0], "minSJ")) > 0, s
    out = str(tmp_path / f"{geo}.msh")
    gmsh.write(out)
    gmsh.clear()
    gmsh.open(out)
    assert 2 not in element_counts(2)
    m = meshio.read(out)
    assert "triangle" not in {c.type for c in m.cells}
    assert sum(len(c.data) for c in m.cells if c.type == "quad") == counts[3]


@pytest.mark.parametrize("version", ["4.1", "2.2"])
def test_recombine_file_in_msh_41_and_22(model, tmp_path, version):
    meshio = pytest.importorskip("meshio")
    gmsh.onelab.setNumber("Parameters/size", [2.7])
    gmsh.open(os.path.join(REPO, "geo", "square_hole.geo"))
    gmsh.model.mesh.generate(2)
    gmsh.option.setNumber("Mesh.MshFileVersion", float(version))
    src = str(tmp_path / "in.msh")
    gmsh.write(src)
    out = tmp_path / "out.msh"
    report = blossomquad.recombine_file(src, out)
    assert report["invalid"] == []
    with open(out) as f:
        f.readline()
        assert f.readline().split()[0] == version
    m = meshio.read(out)
    assert "quad" in {c.type for c in m.cells}
    assert "triangle" not in {c.type for c in m.cells}
