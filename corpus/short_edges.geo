// Built-in planar polygon where tiny edges (1e-3 and 1e-2 long) sit next to edges
// hundreds of times longer, with a local mesh size given only at the points.
DefineConstant[size = 0.2];
Point(1) = {0, 0, 0, size};
Point(2) = {2, 0, 0, size};
Point(3) = {2.001, 0.0, 0, size};
Point(4) = {3, 0, 0, size};
Point(5) = {3, 1, 0, size};
Point(6) = {3, 1.01, 0, size};
Point(7) = {1.5, 2, 0, size};
Point(8) = {1.49, 2.003, 0, size};
Point(9) = {0, 1.5, 0, size};
Point(10) = {0.002, 1.499, 0, size};
For i In {1:10}
  Line(i) = {i, i % 10 + 1};
EndFor
Curve Loop(1) = {1:10};
Plane Surface(1) = {1};
Physical Surface("all") = {1};
