// Second-order test model: the unit sphere (OpenCASCADE: one surface, a seam curve and
// two degenerate pole curves). `-setnumber size S` sets the element size; meshed with
// `-order 2` (6-node triangles on the sphere, 3-node lines on the seam).
DefineConstant[ size = {0.3, Name "size"} ];
SetFactory("OpenCASCADE");
Sphere(1) = {0, 0, 0, 1};
Physical Surface("skin", 7) = {1};
Physical Curve("seam", 8) = Curve{:};
Mesh.MeshSizeMax = size;
Mesh.MeshSizeMin = size;
