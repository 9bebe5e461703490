"""Writes Gmsh's mesh (OpenCASCADE, MSH 4.1) of a box with a thin cylinder fused on its top,
meshed coarser than the cylinder's radius, in one of three variants:

- `folded` (v41_thin_cylinder_folded.msh): radius 0.0573 at size 0.142, about 2.5 times
  the radius: around the cylinder Gmsh's triangles fold over each other (opposite normals
  across an edge) and overlap (an edge of four triangles);
- `wrapped` (v41_thin_pin_wrapped.msh): radius 0.0537 at size 0.110, about twice the
  radius: the cylinder is a few triangles round, so the stars of two nodes on opposite
  sides of it (108 and 494, joined by an edge of two triangles) share four of their six
  neighbours, and a hexagon that an edge swap would cut from one of them to the other lies
  across that edge;
- `own_side` (v41_thin_pin_own_side.msh): radius 0.0779 at size 0.218, about 2.8 times
  the radius: the cylinder's cap is three triangles, and the lateral surface (surface 7)
  wraps round its node 55 so sharply that a face there turns 90 degrees or more from the
  node's area-weighted normal.

Usage: python3 thin_cylinder.py VARIANT OUT.msh
"""

import sys

import gmsh

# variant: (the cylinder's base point, axis and radius; the mesh size)
VARIANTS = {
    "folded": ((0.6080531675021457, 0.4303110009161265, 0.5,
                0.03152749081422662, -0.17381010844190856, 0.8520004499706137,
                0.057309426498244095), 0.14219911718718403),
    "wrapped": ((0.5629890010629022, 0.5665641884499353, 0.5,
                 -0.1429598588298529, -0.19565582276397284, 0.6873772460316823,
                 0.053728533934427405), 0.11004121042489755),
    "own_side": ((0.3561474360305579, 0.3094464588555302, 0.5,
                  0.19945226146916578, -0.1262985417188588, 0.5602960316076625,
                  0.07791046899086365), 0.2183707722112509),
}


def main(variant, out):
    cylinder_args, h = VARIANTS[variant]
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("thin_cylinder")
    box = gmsh.model.occ.addBox(0, 0, 0, 1, 1, 0.5)
    cylinder = gmsh.model.occ.addCylinder(*cylinder_args)
    gmsh.model.occ.fuse([(3, box)], [(3, cylinder)])
    gmsh.model.occ.synchronize()
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    gmsh.option.setNumber("Mesh.MeshSizeMin", h)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.model.mesh.generate(2)
    gmsh.write(out)
    gmsh.finalize()


if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] not in VARIANTS:
        sys.exit(__doc__.strip().splitlines()[-1])
    main(sys.argv[1], sys.argv[2])
