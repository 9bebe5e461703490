// A filleted OpenCASCADE bracket block standing in for the paper's 11-face bone
// model (Remacle et al. 2012, section 8.3): a 2 x 1 x 0.5 block with its four
// vertical edges filleted, a cylindrical boss on top, a through hole in the
// boss and a second through hole in the block, meshed as a surface mesh only
// (`gmsh -2`), with curvature-adapted sizes.
//
//   gmsh -2 cad_solid.geo -o cad_solid.msh                      (~6e3 triangles)
//   gmsh -2 cad_solid.geo -setnumber size 0.25 -o c.msh         (~5e4 triangles)
//
// `size` scales the maximum element size; the triangle count grows like
// 1 / size^2. Curves keep Gmsh's plain node counts by default, so several faces
// have odd triangle counts (parity repair on a closed shell); set odd_curves = 1
// to make every curve's node count odd (see rectangle.geo).

DefineConstant[
  size = {1, Min 0.01, Max 10, Name "Parameters/size"},
  odd_curves = {0, Choices {0, 1}, Name "Parameters/odd curves"}
];

SetFactory("OpenCASCADE");
Mesh.MeshSizeMax = 0.08 * size;
Mesh.MeshSizeMin = 0.005 * size;
Mesh.MeshSizeFromCurvature = 24;
Mesh.MeshSizeFromPoints = 0;

Box(1) = {0, 0, 0, 2, 1, 0.5};
Cylinder(2) = {0.6, 0.5, 0.5, 0, 0, 0.3, 0.3};
body() = BooleanUnion{ Volume{1}; Delete; }{ Volume{2}; Delete; };
Cylinder(3) = {0.6, 0.5, -0.1, 0, 0, 1.0, 0.15};
Cylinder(4) = {1.5, 0.5, -0.1, 0, 0, 0.7, 0.2};
solid() = BooleanDifference{ Volume{body()}; Delete; }{ Volume{3, 4}; Delete; };

// Fillet the four vertical edges of the block.
e = 1e-6;
vertical() = {};
corners() = {0, 0, 2, 0, 0, 1, 2, 1};
For i In {0 : 3}
  cx = corners(2 * i);
  cy = corners(2 * i + 1);
  vertical() += Curve In BoundingBox{cx - e, cy - e, -e, cx + e, cy + e, 0.5 + e};
EndFor
solid() = Fillet{ solid() }{ vertical() }{ 0.2 };

all() = Surface{:};
holes() = Surface In BoundingBox{0.45 - e, 0.35 - e, -e, 0.75 + e, 0.65 + e, 0.8 + e};
holes() += Surface In BoundingBox{1.3 - e, 0.3 - e, -e, 1.7 + e, 0.7 + e, 0.5 + e};
fillets() = {};
For i In {0 : 3}
  cx = corners(2 * i);
  cy = corners(2 * i + 1);
  fillets() += Surface In BoundingBox{cx - 0.2 - e, cy - 0.2 - e, -e, cx + 0.2 + e, cy + 0.2 + e, 0.5 + e};
EndFor
rest() = all();
rest() -= holes();
rest() -= fillets();
boss() = Surface In BoundingBox{0.3 - e, 0.2 - e, 0.5 - e, 0.9 + e, 0.8 + e, 0.8 + e};
boss() -= holes();
rest() -= boss();

Physical Surface("holes", 1) = {holes()};
Physical Surface("fillets", 2) = {fillets()};
Physical Surface("boss", 3) = {boss()};
Physical Surface("block", 4) = {rest()};
Physical Curve("fillet_edges", 5) = Boundary{ Surface{fillets()}; };
Physical Volume("solid", 6) = {solid()};

If (odd_curves)
  caller_recombine_all = Mesh.RecombineAll;
  Mesh.RecombineAll = 1;
  Mesh 1;
  Mesh.RecombineAll = caller_recombine_all;
EndIf
