// Built-in kernel: a face with a round hole extruded with Layers but without Recombine
// (structured triangles on the side faces, two per layer cell), then the top face
// extruded again with Layers and Recombine (quads on those side faces).
DefineConstant[size = 0.25];
Point(1) = {0, 0, 0, size};
Point(2) = {2, 0, 0, size};
Point(3) = {2, 1.5, 0, size};
Point(4) = {0, 1.5, 0, size};
Point(5) = {1, 0.75, 0, size};
Point(6) = {1.3, 0.75, 0, size};
Point(7) = {1, 1.05, 0, size};
Point(8) = {0.7, 0.75, 0, size};
Point(9) = {1, 0.45, 0, size};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Circle(5) = {6, 5, 7}; Circle(6) = {7, 5, 8}; Circle(7) = {8, 5, 9}; Circle(8) = {9, 5, 6};
Curve Loop(1) = {1:4};
Curve Loop(2) = {5:8};
Plane Surface(1) = {1, 2};
a[] = Extrude{0, 0, 0.5}{ Surface{1}; Layers{3}; };
b[] = Extrude{0, 0, 0.3}{ Surface{a[0]}; Layers{2}; Recombine; };
Physical Surface("all") = Surface{:};
