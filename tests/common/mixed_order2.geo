// Second-order test model with quads already in the input: a 2 x 2 square meshed
// transfinite and recombined (Gmsh writes 9-node quads with -order 2, 8-node with
// Mesh.SecondOrderIncomplete = 1) beside a triangle-meshed face bounded by a circular arc.
// `-setnumber size S` sets the triangle size; meshed with `-order 2`.
DefineConstant[ size = {0.3, Name "size"} ];
Point(1) = {0, 0, 0, size};
Point(2) = {2, 0, 0, size};
Point(3) = {2, 2, 0, size};
Point(4) = {0, 2, 0, size};
Point(5) = {2, 1, 0, size};  // centre of the arc
Point(6) = {3, 1, 0, size};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Circle(5) = {2, 5, 6};
Circle(6) = {6, 5, 3};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Curve Loop(2) = {5, 6, -2};
Plane Surface(2) = {2};
n = Ceil(2 / size) + 1;
Transfinite Curve{1, 2, 3, 4} = n;
Transfinite Surface{1};
Recombine Surface{1};
Physical Surface("quads", 1) = {1};
Physical Surface("triangles", 2) = {2};
Physical Curve("edges", 3) = {1, 2, 3, 4, 5, 6};
