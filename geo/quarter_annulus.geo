// A quarter annulus, 1 <= r <= 2, x, y >= 0: a planar model with curved boundaries for
// the finite-element round trips (Poisson with a manufactured solution, solved on the
// quads by scikit-fem and DOLFINx). Physical groups: the surface "domain" (1), the arcs
// "inner" (2) and "outer" (3), the straight sides "axes" (4).
//
//   gmsh -2 quarter_annulus.geo -setnumber size 0.1 -o annulus.msh
//   gmsh -2 -order 2 quarter_annulus.geo -setnumber size 0.1 -o annulus.msh

DefineConstant[
  size = {0.1, Min 0.001, Max 1, Name "Parameters/size"}
];

Point(1) = {0, 0, 0, size};
Point(2) = {1, 0, 0, size};
Point(3) = {2, 0, 0, size};
Point(4) = {0, 2, 0, size};
Point(5) = {0, 1, 0, size};
Line(1) = {2, 3};
Circle(2) = {3, 1, 4};
Line(3) = {4, 5};
Circle(4) = {5, 1, 2};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Physical Surface("domain", 1) = {1};
Physical Curve("inner", 2) = {4};
Physical Curve("outer", 3) = {2};
Physical Curve("axes", 4) = {1, 3};
