"""RVE for homogenization: a unit cube with spherical inclusions cut at its 8 corners and
one at its centre (BooleanFragments, so inclusion and matrix share faces), its three
pairs of opposite faces made periodic with gmsh.model.mesh.setPeriodic (translations).
Surface mesh only.

    python3 corpus/periodic_rve.py SIZE OUTPUT.msh [Option.Name=VALUE ...]
"""

import gmsh

import _model

size, output, tmp = _model.start("periodic_rve")
occ = gmsh.model.occ
box = occ.addBox(0, 0, 0, 1, 1, 1)
balls = [(3, occ.addSphere(0.5, 0.5, 0.5, 0.25))]
for x in (0, 1):
    for y in (0, 1):
        for z in (0, 1):
            ball = occ.addSphere(x, y, z, 0.3)
            piece, _ = occ.intersect([(3, ball)], [(3, occ.addBox(0, 0, 0, 1, 1, 1))])
            balls += piece
occ.fragment([(3, box)], balls)
occ.synchronize()
eps = 1e-6
gmsh.option.setNumber("Mesh.MeshSizeMax", size)

def faces_on(axis, value):
    lo = [-eps, -eps, -eps]
    hi = [1 + eps, 1 + eps, 1 + eps]
    lo[axis], hi[axis] = value - eps, value + eps
    return [t for _, t in gmsh.model.getEntitiesInBoundingBox(*lo, *hi, 2)]

for axis in range(3):
    shift = [0.0, 0.0, 0.0]
    shift[axis] = 1.0
    affine = [1, 0, 0, shift[0], 0, 1, 0, shift[1], 0, 0, 1, shift[2], 0, 0, 0, 1]
    for m in faces_on(axis, 0.0):
        box_m = gmsh.model.getBoundingBox(2, m)
        for s in faces_on(axis, 1.0):
            box_s = gmsh.model.getBoundingBox(2, s)
            if all(abs(box_s[i] - box_m[i] - shift[i % 3]) < 1e-5 for i in range(6)):
                gmsh.model.mesh.setPeriodic(2, [s], [m], affine)

gmsh.model.addPhysicalGroup(2, [t for _, t in gmsh.model.getEntities(2)], name="faces")
_model.finish(output, tmp)
