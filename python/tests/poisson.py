"""Poisson with a manufactured solution on meshes from Gmsh and blossomquad, solved by
scikit-fem and DOLFINx: what the solver tests (test_skfem.py, test_dolfinx.py) and
scripts/bench_solvers.py share.

The problem: -Δu = f on the quarter annulus of geo/quarter_annulus.geo, u = g on its whole
boundary (the physical curves "inner", "outer" and "axes"), with u = sin(3x) sin(2y), so
f = 13 u. Lagrange elements of the mesh's own order (P1/Q1 on linear meshes, P2/Q2 on
6-node triangles and 9-node quads); errors in L2 and in the H1 seminorm.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence

import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
GEO = os.path.join(REPO, "geo", "quarter_annulus.geo")
# the physical curves of GEO; together they are its whole boundary
BOUNDARY = {"inner": 2, "outer": 3, "axes": 4}
# the mesh sizes of the convergence runs (each half the last)
SIZES = (0.2, 0.1, 0.05)


def exact(x, y):
    return np.sin(3 * x) * np.sin(2 * y)


def exact_grad(x, y):
    return 3 * np.cos(3 * x) * np.sin(2 * y), 2 * np.sin(3 * x) * np.cos(2 * y)


def source(x, y):
    return 13 * exact(x, y)


@dataclass
class Solution:
    """One solve: unknowns, elements, L2 and H1-seminorm errors."""

    dofs: int
    cells: int
    l2: float
    h1: float


def run(cmd: Sequence[str]) -> None:
    """Runs `cmd`; raises with its output when it fails."""
    out = subprocess.run(list(cmd), capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({out.returncode}):\n{out.stdout}\n{out.stderr}")


def gmsh_exe() -> str:
    return os.environ.get("GMSH", "gmsh")


def blossomquad_exe() -> str:
    return os.environ.get("BLOSSOMQUAD", shutil.which("blossomquad") or "blossomquad")


def mesh(out: str, size: float, order: int = 1, fmt: Optional[str] = None, binary: bool = False,
         geo: str = GEO) -> str:
    """`gmsh -2 [-order 2] GEO -setnumber size SIZE [-format FMT] [-bin] -o OUT` (without
    FMT, Gmsh's default MSH 4.1: GUIDE.md's command)."""
    cmd = [gmsh_exe(), "-2", geo, "-setnumber", "size", str(size)]
    if fmt:
        cmd += ["-format", fmt]
    if order == 2:
        cmd[2:2] = ["-order", "2"]
    if binary:
        cmd.append("-bin")
    run(cmd + ["-o", out])
    return out


def recombine(inp: str, out: str, *flags: str) -> str:
    """`blossomquad IN -o OUT` (the README's and GUIDE.md's command)."""
    run([blossomquad_exe(), inp, "-o", out, "-q", *flags])
    return out


def rate(results: List[Solution]) -> List[float]:
    """Observed L2 orders between successive runs, h ~ dofs^(-1/2)."""
    return [
        -2 * np.log(b.l2 / a.l2) / np.log(b.dofs / a.dofs) for a, b in zip(results, results[1:])
    ]


# ---------------------------------------------------------------------------- scikit-fem

def physical_boundary_points(path: str) -> Dict[str, np.ndarray]:
    """The coordinates of the nodes of each physical curve of BOUNDARY (from the file's
    line elements, through meshio): the Dirichlet nodes the physical tags give."""
    import meshio

    m = meshio.read(path)
    out: Dict[str, List[int]] = {name: [] for name in BOUNDARY}
    tag_of = {tag: name for name, tag in BOUNDARY.items()}
    for block, phys in zip(m.cells, m.cell_data["gmsh:physical"]):
        if block.type not in ("line", "line3"):
            continue
        for conn, p in zip(block.data, phys):
            if int(p) in tag_of:
                out[tag_of[int(p)]].extend(int(i) for i in conn)
    return {name: m.points[np.unique(ix)][:, :2] for name, ix in out.items()}


def dofs_at(basis, points: np.ndarray) -> np.ndarray:
    """The DOFs of a Lagrange `basis` located at `points` (to 1e-9); raises when one has
    none."""
    locs = basis.doflocs.T
    scale = 1e9
    index = {tuple(np.round(p * scale).astype(np.int64)): i for i, p in enumerate(locs)}
    found = [index.get(tuple(np.round(p * scale).astype(np.int64))) for p in points]
    missing = [tuple(p) for p, f in zip(points, found) if f is None]
    if missing:
        raise AssertionError(f"{len(missing)} boundary nodes have no DOF, e.g. {missing[:3]}")
    return np.unique(np.array(found, dtype=np.int64))


def skfem_solve(path: str) -> Solution:
    """Loads `path` with scikit-fem (through meshio) and solves the problem with the
    Lagrange element of the mesh's order; the Dirichlet DOFs are those at the nodes of the
    physical boundary curves, which must be exactly the mesh's boundary DOFs."""
    import skfem
    from skfem.helpers import dot, grad

    m = skfem.Mesh.load(path)
    element = {
        skfem.MeshTri1: skfem.ElementTriP1,
        skfem.MeshQuad1: skfem.ElementQuad1,
        skfem.MeshTri2: skfem.ElementTriP2,
        skfem.MeshQuad2: skfem.ElementQuad2,
    }[type(m)]()
    basis = skfem.Basis(m, element, intorder=8)

    @skfem.BilinearForm
    def laplace(u, v, _):
        return dot(grad(u), grad(v))

    @skfem.LinearForm
    def load(v, w):
        return source(w.x[0], w.x[1]) * v

    groups = physical_boundary_points(path)
    dirichlet = np.unique(np.concatenate([dofs_at(basis, p) for p in groups.values()]))
    boundary = basis.get_dofs().flatten()
    if not np.array_equal(np.sort(boundary), dirichlet):
        raise AssertionError(
            f"physical boundary curves give {len(dirichlet)} DOFs, the mesh boundary {len(boundary)}"
        )
    if m.boundaries:  # linear meshes: scikit-fem's own reading of the physical curves
        own = np.unique(np.concatenate([basis.get_dofs(m.boundaries[n]).flatten() for n in BOUNDARY]))
        if not np.array_equal(own, dirichlet):
            raise AssertionError("scikit-fem's boundaries differ from the physical curves")
    A = laplace.assemble(basis)
    b = load.assemble(basis)
    x = np.zeros(basis.N)
    x[dirichlet] = exact(*basis.doflocs[:, dirichlet])
    u = skfem.solve(*skfem.condense(A, b, x=x, D=dirichlet))

    @skfem.Functional
    def l2(w):
        return (w["uh"] - exact(w.x[0], w.x[1])) ** 2

    @skfem.Functional
    def h1(w):
        ex, ey = exact_grad(w.x[0], w.x[1])
        gx, gy = w["uh"].grad
        return (gx - ex) ** 2 + (gy - ey) ** 2

    uh = basis.interpolate(u)
    return Solution(
        dofs=basis.N,
        cells=m.nelements,
        l2=float(np.sqrt(l2.assemble(basis, uh=uh))),
        h1=float(np.sqrt(h1.assemble(basis, uh=uh))),
    )


# ------------------------------------------------------------------------------- DOLFINx

def dolfinx_solve(mesh_data) -> Solution:
    """Solves the problem with DOLFINx on `mesh_data` (what `dolfinx.io.gmsh.read_from_msh`
    and `model_to_mesh` return), Lagrange of the mesh's geometric degree; the Dirichlet DOFs
    are those of the facets tagged with the physical boundary curves, which must be exactly
    the boundary's."""
    import dolfinx
    import ufl
    from dolfinx import fem
    from dolfinx.fem.petsc import LinearProblem
    from mpi4py import MPI

    domain = mesh_data.mesh
    tags = mesh_data.facet_tags
    degree = geometry_degree(domain)
    V = fem.functionspace(domain, ("Lagrange", degree))
    tdim = domain.topology.dim
    domain.topology.create_connectivity(tdim - 1, tdim)
    facets = np.unique(np.concatenate([tags.find(t) for t in BOUNDARY.values()]))
    dofs = fem.locate_dofs_topological(V, tdim - 1, facets)
    boundary = fem.locate_dofs_topological(V, tdim - 1, dolfinx.mesh.exterior_facet_indices(domain.topology))
    if not np.array_equal(np.sort(dofs), np.sort(boundary)):
        raise AssertionError(
            f"physical boundary facets give {len(dofs)} DOFs, the mesh boundary {len(boundary)}"
        )
    g = fem.Function(V)
    g.interpolate(lambda X: exact(X[0], X[1]))
    bc = fem.dirichletbc(g, dofs)
    x = ufl.SpatialCoordinate(domain)
    u_ex = ufl.sin(3 * x[0]) * ufl.sin(2 * x[1])
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    a = ufl.inner(ufl.grad(u), ufl.grad(v)) * ufl.dx
    L = 13 * u_ex * v * ufl.dx
    problem = LinearProblem(
        a, L, bcs=[bc], petsc_options_prefix="poisson_",
        petsc_options={"ksp_type": "preonly", "pc_type": "lu"},
    )
    uh = problem.solve()
    dx = ufl.dx(metadata={"quadrature_degree": 8})
    comm = domain.comm
    l2 = comm.allreduce(fem.assemble_scalar(fem.form((uh - u_ex) ** 2 * dx)), op=MPI.SUM)
    d = ufl.grad(uh - u_ex)
    h1 = comm.allreduce(fem.assemble_scalar(fem.form(ufl.inner(d, d) * dx)), op=MPI.SUM)
    cells = domain.topology.index_map(tdim).size_global
    return Solution(dofs=V.dofmap.index_map.size_global, cells=cells, l2=float(np.sqrt(l2)),
                    h1=float(np.sqrt(h1)))


def geometry_degree(domain) -> int:
    """The degree of a DOLFINx mesh's coordinate element."""
    g = domain.geometry
    return (g.cmaps[0] if hasattr(g, "cmaps") else g.cmap).degree


def dolfinx_read(path: str, gdim: int = 2):
    """`dolfinx.io.gmsh.read_from_msh(path, MPI.COMM_WORLD, 0, gdim=gdim)` (GUIDE.md's
    line)."""
    from dolfinx.io import gmsh as gmshio
    from mpi4py import MPI

    return gmshio.read_from_msh(path, MPI.COMM_WORLD, 0, gdim=gdim)


def dolfinx_from_model(size: float, order: int = 1, geo: str = GEO, gdim: int = 2,
                       options: Optional[dict] = None, counts: Optional[dict] = None):
    """In one process: Gmsh meshes `geo`, `blossomquad.recombine_gmsh()` recombines the
    open model, `dolfinx.io.gmsh.model_to_mesh` reads it (GUIDE.md's lines). `counts`,
    when given, gets the model's "quads" (4- and 9-node), its "nodes" and how many of them
    the physical groups' elements "used"."""
    import gmsh
    from dolfinx.io import gmsh as gmshio
    from mpi4py import MPI

    import blossomquad

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.onelab.setNumber("Parameters/size", [size])
        gmsh.open(geo)
        gmsh.model.mesh.generate(2)
        if order == 2:
            gmsh.model.mesh.setOrder(2)
        blossomquad.recombine_gmsh(**(options or {}))
        if counts is not None:
            counts["quads"] = sum(len(gmsh.model.mesh.getElementsByType(t)[0]) for t in (3, 10))
            used = set()
            for d, g in gmsh.model.getPhysicalGroups():
                for e in gmsh.model.getEntitiesForPhysicalGroup(d, g):
                    for conn in gmsh.model.mesh.getElements(d, e)[2]:
                        used.update(int(n) for n in conn)
            counts["nodes"] = len(gmsh.model.mesh.getNodes()[0])
            counts["used"] = len(used)
        return gmshio.model_to_mesh(gmsh.model, MPI.COMM_WORLD, 0, gdim=gdim)
    finally:
        gmsh.finalize()
