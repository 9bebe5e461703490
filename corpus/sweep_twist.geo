// Built-in kernel: a square with a hole extruded with a twist (ruled, warped side faces).
DefineConstant[size = 0.2];
Point(1) = {-0.5, -0.5, 0, size}; Point(2) = {0.5, -0.5, 0, size};
Point(3) = {0.5, 0.5, 0, size}; Point(4) = {-0.5, 0.5, 0, size};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1:4};
Plane Surface(1) = {1};
Extrude{{0, 0, 1}, {0, 0, 1}, {0, 0, 0}, Pi / 3}{ Surface{1}; }
Physical Surface("all") = Surface{:};
