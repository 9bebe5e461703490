"""DOLFINx reads blossomquad's output as it is and solves on it: `read_from_msh` on the
file written by `blossomquad` (geo/quarter_annulus.geo meshed by `gmsh -2`, linear and
`-order 2`), `model_to_mesh` on the model `blossomquad.recombine_gmsh()` leaves, the same
Poisson problem as test_skfem.py (poisson.py) converging at the expected rates with the
same errors as scikit-fem's on the same mesh; and both readers on every geo/ fixture in
MSH 4.1 and 2.2, linear and second order. Runs in the venv scripts/test.sh makes for
DOLFINx (`dolfinx-solver-real`, Python >= 3.12)."""

import glob
import os

import numpy as np
import pytest

import poisson
from solver_gate import require

RATE_BAND = (-0.3, 0.45)


@pytest.fixture(autouse=True)
def _dolfinx():
    require("dolfinx", "pip install dolfinx-solver-real (Python >= 3.12; LD_LIBRARY_PATH=VENV/lib)")


@pytest.mark.parametrize("order", [1, 2])
def test_read_from_msh_solves_and_converges_like_scikit_fem(tmp_path, order):
    results = []
    for size in poisson.SIZES:
        tri = poisson.mesh(str(tmp_path / f"tri-{size}.msh"), size, order)
        quad = poisson.recombine(tri, str(tmp_path / f"quad-{size}.msh"))
        data = poisson.dolfinx_read(quad)
        assert data.mesh.topology.cell_type.name == "quadrilateral"
        assert poisson.geometry_degree(data.mesh) == order
        sol = poisson.dolfinx_solve(data)
        results.append(sol)
        if importable("skfem"):
            ref = poisson.skfem_solve(quad)
            assert sol.dofs == ref.dofs and sol.cells == ref.cells, (sol, ref)
            assert abs(sol.l2 - ref.l2) <= 0.02 * ref.l2, (sol, ref)
    rates = poisson.rate(results)
    expected = order + 1
    assert all(expected + RATE_BAND[0] <= r <= expected + RATE_BAND[1] for r in rates), (
        rates, results)


@pytest.mark.parametrize("order", [1, 2])
def test_model_to_mesh_after_recombine_gmsh_solves_the_same(tmp_path, order):
    size = poisson.SIZES[1]
    data = poisson.dolfinx_from_model(size, order)
    assert data.mesh.topology.cell_type.name == "quadrilateral"
    sol = poisson.dolfinx_solve(data)
    tri = poisson.mesh(str(tmp_path / "tri.msh"), size, order)
    ref = poisson.dolfinx_solve(poisson.dolfinx_read(poisson.recombine(tri, str(tmp_path / "q.msh"))))
    # the same mesh in memory as in the file
    assert sol.dofs == ref.dofs and abs(sol.l2 - ref.l2) <= 1e-6 * ref.l2, (sol, ref)


def importable(name):
    try:
        __import__(name)
        return True
    except ImportError:
        return False


FIXTURE_SIZES = {"rectangle": 1.0, "square_hole": 4.0, "cad_solid": 1.5, "even_curves": 1.0,
                 "quarter_annulus": 0.1}
FIXTURES = sorted(os.path.splitext(os.path.basename(p))[0]
                  for p in glob.glob(os.path.join(poisson.REPO, "geo", "*.geo")))


def cells_in_file(path):
    """Quads (4- or 9-node) in the MSH file, through Gmsh."""
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(path)
        tags = gmsh.model.mesh.getNodes()[0]
        n = sum(len(gmsh.model.mesh.getElementsByType(t)[0]) for t in (3, 10))
        return n, len(tags)
    finally:
        gmsh.finalize()


@pytest.mark.parametrize("fixture", FIXTURES)
@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("fmt", [("msh41", False), ("msh22", True)], ids=["4.1", "2.2-binary"])
def test_both_readers_take_every_fixture(tmp_path, fixture, order, fmt):
    geo = os.path.join(poisson.REPO, "geo", f"{fixture}.geo")
    size = FIXTURE_SIZES.get(fixture, 1.0)
    gdim = 2 if fixture in ("rectangle", "square_hole", "even_curves", "quarter_annulus") else 3
    tri = poisson.mesh(str(tmp_path / "tri.msh"), size, order, fmt[0], fmt[1], geo=geo)
    quad = poisson.recombine(tri, str(tmp_path / "quad.msh"))
    quads, nodes = cells_in_file(quad)
    data = poisson.dolfinx_read(quad, gdim=gdim)
    assert data.mesh.topology.index_map(2).size_global == quads
    assert data.mesh.geometry.x.shape[0] == nodes
    # in one process (Gmsh's model of the .geo, not the file: its mesh may differ slightly)
    counted = {}
    model = poisson.dolfinx_from_model(size, order, geo=geo, gdim=gdim, counts=counted)
    assert model.mesh.topology.index_map(2).size_global == counted["quads"] > 0
    # DOLFINx keeps the nodes of the physical groups' elements (not a circle's centre point)
    assert model.mesh.geometry.x.shape[0] == counted["used"] <= counted["nodes"]


def corpus_dir():
    """The real MSH corpus (`$BLOSSOMQUAD_CORPUS`, else ../shared/corpus/real-msh beside the
    repository, as for the Rust tests), or None."""
    d = os.environ.get("BLOSSOMQUAD_CORPUS") or os.path.join(poisson.REPO, "..", "shared", "corpus",
                                                              "real-msh")
    return d if os.path.isdir(d) else None


def has_physical_groups(path):
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(path)
        return bool(gmsh.model.getPhysicalGroups())
    finally:
        gmsh.finalize()


@pytest.mark.parametrize("fmt", [["--format", "msh41"], ["--format", "msh22", "--binary"]],
                         ids=["4.1", "2.2-binary"])
def test_read_from_msh_takes_every_corpus_model(tmp_path, fmt):
    """Every model of the real corpus, converted to the variant, recombined (volumes
    dropped where it has any): DOLFINx reads the output whenever the model has a physical
    group (without one it refuses Gmsh's own files too, and says so)."""
    corpus = corpus_dir()
    if corpus is None:
        pytest.skip("the real MSH corpus is absent (set BLOSSOMQUAD_CORPUS to run this test)")
    files = sorted(glob.glob(os.path.join(corpus, "*.msh")))
    assert files, f"no .msh in {corpus}"
    read = 0
    for f in files:
        inp = str(tmp_path / "in.msh")
        out = str(tmp_path / "out.msh")
        poisson.run([poisson.blossomquad_exe(), "convert", f, "-o", inp, *fmt])
        try:
            poisson.recombine(inp, out)
        except RuntimeError as e:
            if "volume" not in str(e):
                raise
            poisson.recombine(inp, out, "--drop-volumes")
        if has_physical_groups(out):
            data = poisson.dolfinx_read(out, gdim=3)
            assert data.mesh.topology.index_map(data.mesh.topology.dim).size_global > 0, f
            read += 1
        else:
            with pytest.raises(RuntimeError, match="physical groups"):
                poisson.dolfinx_read(out, gdim=3)
    assert read >= len(files) // 2, f"only {read} of {len(files)} models have physical groups"
