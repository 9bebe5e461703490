// The paper's 3 x 1 rectangle (Remacle et al. 2012, section 3, Figure 1) with the
// analytical size field h(x, y) = 0.1 + 0.08 sin(3x) cos(6y).
//
//   gmsh -2 rectangle.geo -o rectangle.msh                    (1792 triangles)
//   gmsh -2 rectangle.geo -setnumber size 0.134 -o r.msh      (~9e4 triangles)
//
// `size` multiplies h; the triangle count grows like 1 / size^2.
// Every curve gets an odd number of nodes (even number of segments), so the
// surface has an even number of triangles and can be recombined all-quad
// without parity repair: the 1D mesh is generated with Mesh.RecombineAll = 1
// (Gmsh's 1D mesher then bumps each curve to an odd node count), after which the
// option is restored to the caller's value for the 2D mesh (so
// `-setnumber Mesh.RecombineAll 1` still asks Gmsh to recombine).
// Set `odd_curves` to 0 for Gmsh's plain curve node counts.

DefineConstant[
  size = {1, Min 0.01, Max 10, Name "Parameters/size"},
  odd_curves = {1, Choices {0, 1}, Name "Parameters/odd curves"}
];

Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 0;
Mesh.MeshSizeExtendFromBoundary = 0;

Point(1) = {0, 0, 0};
Point(2) = {3, 0, 0};
Point(3) = {3, 1, 0};
Point(4) = {0, 1, 0};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};

Physical Curve("bottom", 1) = {1};
Physical Curve("right", 2) = {2};
Physical Curve("top", 3) = {3};
Physical Curve("left", 4) = {4};
Physical Surface("domain", 10) = {1};

Field[1] = MathEval;
Field[1].F = Sprintf("%.17g * (0.1 + 0.08 * sin(3 * x) * cos(6 * y))", size);
Background Field = 1;

If (odd_curves)
  caller_recombine_all = Mesh.RecombineAll;
  Mesh.RecombineAll = 1;
  Mesh 1;
  Mesh.RecombineAll = caller_recombine_all;
EndIf
