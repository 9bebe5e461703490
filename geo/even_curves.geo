// A plain `gmsh -2` mesh whose curves all have an even number of nodes (an odd
// number of segments), so that surfaces bounded by an odd number of curves get
// an odd number of triangles and cannot be recombined all-quad as they are:
// the fixture for parity repair (and `--parity error`).
//
//   square (4 curves, even)   triangle on top (3 curves, odd)
//   pentagon on the right (5 curves, odd); the three share curves.
//
//   gmsh -2 even_curves.geo -o even_curves.msh                  (~2.5e3 triangles)
//   gmsh -2 even_curves.geo -setnumber size 0.3 -o e.msh        (~2.8e4 triangles)
//
// `size` scales the element size (0.05 at size = 1); every curve is
// `Transfinite` with 2 * round(length / (2 h)) nodes (even, at least 2).

DefineConstant[
  size = {1, Min 0.01, Max 10, Name "Parameters/size"}
];

h = 0.05 * size;
Mesh.MeshSizeMax = h;
Mesh.MeshSizeMin = h;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 0;

Point(1) = {0, 0, 0};
Point(2) = {1, 0, 0};
Point(3) = {1, 1, 0};
Point(4) = {0, 1, 0};
Point(5) = {0.5, 1.7, 0};
Point(6) = {1.8, -0.2, 0};
Point(7) = {2.3, 0.5, 0};
Point(8) = {1.7, 1.3, 0};

Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Line(5) = {3, 5};
Line(6) = {5, 4};
Line(7) = {2, 6};
Line(8) = {6, 7};
Line(9) = {7, 8};
Line(10) = {8, 3};

Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Curve Loop(2) = {-3, 5, 6};
Plane Surface(2) = {2};
Curve Loop(3) = {7, 8, 9, 10, -2};
Plane Surface(3) = {3};

For c In {1 : 10}
  ends() = PointsOf{ Curve{c}; };
  p() = Point{ends(0)};
  q() = Point{ends(1)};
  len = Sqrt((q(0) - p(0))^2 + (q(1) - p(1))^2);
  n = 2 * Round(len / (2 * h));
  If (n < 2)
    n = 2;
  EndIf
  Transfinite Curve{c} = n;
EndFor

Physical Curve("walls", 1) = {1, 4, 6, 5, 7, 8, 9, 10};
Physical Curve("interfaces", 2) = {2, 3};
Physical Surface("square", 10) = {1};
Physical Surface("triangle", 11) = {2};
Physical Surface("pentagon", 12) = {3};
