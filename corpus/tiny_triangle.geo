// Tiny model: a planar triangle and a planar quadrilateral sharing an edge, meshed with a
// size larger than the model, so each surface has 1 to 3 triangles.
DefineConstant[size = 10];
Point(1) = {0, 0, 0, size}; Point(2) = {1, 0, 0, size};
Point(3) = {0.5, 0.8, 0, size}; Point(4) = {1.3, 0.7, 0, size}; Point(5) = {1.2, 1.5, 0, size};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 1};
Line(4) = {2, 4}; Line(5) = {4, 5}; Line(6) = {5, 3};
Curve Loop(1) = {1, 2, 3};
Plane Surface(1) = {1};
Curve Loop(2) = {4, 5, 6, -2};
Plane Surface(2) = {2};
Physical Surface("a") = {1};
Physical Surface("b") = {2};
