// Built-in box whose opposite faces are periodic (`Periodic Surface` with translations):
// the slave faces' meshes are copies of the masters'.
DefineConstant[size = 0.25];
Point(1) = {0, 0, 0, size}; Point(2) = {1, 0, 0, size};
Point(3) = {1, 1, 0, size}; Point(4) = {0, 1, 0, size};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1:4};
Plane Surface(1) = {1};
e[] = Extrude{0, 0, 1.2}{ Surface{1}; };
// e[0] top, e[2..5] sides built on curves 1..4
Periodic Surface{e[0]} = {1} Translate{0, 0, 1.2};
Periodic Surface{e[4]} = {e[2]} Translate{0, 1, 0};
Physical Surface("all") = Surface{:};
