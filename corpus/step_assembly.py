"""Multi-solid STEP assembly: an OCC script builds a plate, a bolt-like cylinder through it,
a bracket (two boxes) resting on it and a separate ball, writes them to a STEP file in a
temporary directory, then imports that file as a new model and glues the touching solids
with BooleanFragments (conforming shared faces), as one does with a CAD assembly.

    python3 corpus/step_assembly.py SIZE OUTPUT.msh [Option.Name=VALUE ...]
"""

import os

import gmsh

import _model

size, output, tmp = _model.start("step_assembly")
occ = gmsh.model.occ
plate = occ.addBox(0, 0, 0, 3, 2, 0.3)
bolt = occ.addCylinder(0.6, 1, -0.3, 0, 0, 1.0, 0.2)
upright = occ.addBox(1.5, 0.5, 0.3, 0.3, 1.0, 1.2)
foot = occ.addBox(1.8, 0.5, 0.3, 0.8, 1.0, 0.2)
bracket, _ = occ.fuse([(3, upright)], [(3, foot)])
ball = occ.addSphere(4, 1, 0.5, 0.5)
occ.synchronize()
step = os.path.join(tmp, "assembly.step")
gmsh.write(step)

gmsh.clear()
gmsh.model.add("step_assembly_import")
shapes = occ.importShapes(step)
occ.removeAllDuplicates()
occ.synchronize()
gmsh.option.setNumber("Mesh.MeshSizeMax", size)
for i, (_, vol) in enumerate(gmsh.model.getEntities(3)):
    faces = [t for _, t in gmsh.model.getBoundary([(3, vol)], oriented=False)]
    # a shared face belongs to the first solid that claims it
    taken = {int(f) for _, g in gmsh.model.getPhysicalGroups(2) for f in gmsh.model.getEntitiesForPhysicalGroup(2, g)}
    faces = [f for f in faces if f not in taken]
    if faces:
        gmsh.model.addPhysicalGroup(2, faces, name=f"solid{i + 1}")
_model.finish(output, tmp)
