// Built-in kernel: an L-shaped face extruded with Layers and Recombine, so the side faces
// are already structured quads in the input; the top and bottom faces are triangles.
DefineConstant[size = 0.25];
Point(1) = {0, 0, 0, size};
Point(2) = {2, 0, 0, size};
Point(3) = {2, 1, 0, size};
Point(4) = {1, 1, 0, size};
Point(5) = {1, 2, 0, size};
Point(6) = {0, 2, 0, size};
For i In {1:6}
  Line(i) = {i, i % 6 + 1};
EndFor
Curve Loop(1) = {1:6};
Plane Surface(1) = {1};
out[] = Extrude{0, 0, 0.6}{ Surface{1}; Layers{Ceil(0.6 / size)}; Recombine; };
Physical Surface("all") = Surface{:};
