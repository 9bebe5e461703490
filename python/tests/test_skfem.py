"""scikit-fem solves Poisson (manufactured solution, poisson.py) on blossomquad's output
of geo/quarter_annulus.geo meshed by `gmsh -2` (4-node quads) and `gmsh -2 -order 2`
(9-node quads) at three sizes: the L2 error converges at order 2 (Q1) and 3 (Q2), and the
physical boundary curves give exactly the mesh's boundary nodes as Dirichlet nodes."""

import pytest

import poisson
from solver_gate import require

# observed orders are estimated on unstructured meshes: a band around the theory
RATE_BAND = (-0.3, 0.45)


@pytest.fixture(autouse=True)
def _skfem():
    require("skfem", "pip install scikit-fem meshio")


@pytest.mark.parametrize("order", [1, 2])
def test_skfem_converges_on_the_quads_at_the_expected_rate(tmp_path, order):
    quads = []
    tris = []
    for size in poisson.SIZES:
        tri = poisson.mesh(str(tmp_path / f"tri-{size}.msh"), size, order)
        quad = poisson.recombine(tri, str(tmp_path / f"quad-{size}.msh"))
        quads.append(poisson.skfem_solve(quad))
        tris.append(poisson.skfem_solve(tri))
    expected = order + 1
    for rates in (poisson.rate(quads), poisson.rate(tris)):
        assert all(expected + RATE_BAND[0] <= r <= expected + RATE_BAND[1] for r in rates), (
            rates, quads, tris)
    # the quads solve the same problem about as well as the triangles they came from
    for q, t in zip(quads, tris):
        assert q.dofs < t.dofs * 1.05 and q.h1 < 1.5 * t.h1, (q, t)


@pytest.mark.parametrize("order", [1, 2])
def test_skfem_gets_the_same_solution_from_msh_22_binary(tmp_path, order):
    size = poisson.SIZES[1]
    sol = []
    for fmt, binary in (("msh41", False), ("msh22", True)):
        tri = poisson.mesh(str(tmp_path / f"tri-{fmt}.msh"), size, order, fmt, binary)
        quad = poisson.recombine(tri, str(tmp_path / f"quad-{fmt}.msh"))
        sol.append(poisson.skfem_solve(quad))
    assert sol[0].dofs == sol[1].dofs
    assert abs(sol[0].l2 - sol[1].l2) <= 1e-9 * sol[0].l2, sol
