// Built-in kernel: a trapezoid revolved 3 x 90 degrees about the z axis with Layers and
// Recombine: the swept faces are structured quads in the input, the end caps triangles.
DefineConstant[size = 0.2];
Point(1) = {1, 0, 0, size};
Point(2) = {2, 0, 0, size};
Point(3) = {1.8, 0, 1, size};
Point(4) = {1.2, 0, 0.8, size};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1:4};
Plane Surface(1) = {1};
a[] = Extrude{{0, 0, 1}, {0, 0, 0}, Pi / 2}{ Surface{1}; Layers{Ceil(2.4 / size)}; Recombine; };
b[] = Extrude{{0, 0, 1}, {0, 0, 0}, Pi / 2}{ Surface{a[0]}; Layers{Ceil(2.4 / size)}; Recombine; };
c[] = Extrude{{0, 0, 1}, {0, 0, 0}, Pi / 2}{ Surface{b[0]}; Layers{Ceil(2.4 / size)}; Recombine; };
Physical Surface("all") = Surface{:};
