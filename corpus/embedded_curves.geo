// Planar face with embedded curves (a polyline crack and a closed curve) and embedded points:
// segments inside the face that must stay edges.
DefineConstant[size = 0.15];
Point(1) = {0, 0, 0, size}; Point(2) = {2, 0, 0, size};
Point(3) = {2, 1.5, 0, size}; Point(4) = {0, 1.5, 0, size};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1:4};
Plane Surface(1) = {1};
Point(10) = {0.3, 0.3, 0, size / 3}; Point(11) = {0.8, 0.5, 0, size};
Point(12) = {1.0, 0.4, 0, size}; Point(13) = {1.05, 0.41, 0, size / 3};
Line(10) = {10, 11}; Line(11) = {11, 12}; Line(12) = {12, 13};
Point(20) = {1.5, 1.0, 0, size}; Point(21) = {1.7, 1.0, 0, size}; Point(22) = {1.5, 1.2, 0, size};
Point(23) = {1.3, 1.0, 0, size}; Point(24) = {1.5, 0.8, 0, size};
Circle(20) = {21, 20, 22}; Circle(21) = {22, 20, 23}; Circle(22) = {23, 20, 24}; Circle(23) = {24, 20, 21};
Point(30) = {0.5, 1.1, 0, size / 5}; Point(31) = {0.52, 1.1, 0, size / 5};
Curve{10, 11, 12, 20:23} In Surface{1};
Point{30, 31} In Surface{1};
Physical Surface("plate") = {1};
