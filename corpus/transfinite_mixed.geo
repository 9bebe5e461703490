// Built-in box whose bottom and one side face are transfinite and recombined (quads in
// the input), the other faces unstructured triangles.
DefineConstant[size = 0.25];
Point(1) = {0, 0, 0, size}; Point(2) = {1, 0, 0, size};
Point(3) = {1, 1, 0, size}; Point(4) = {0, 1, 0, size};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1:4};
Plane Surface(1) = {1};
e[] = Extrude{0, 0, 0.8}{ Surface{1}; };
Transfinite Curve{1:4} = Ceil(1 / size) + 1;
Transfinite Surface{1};
Recombine Surface{1};
// e[2] is the side face built on curve 1
Transfinite Curve{Boundary{ Surface{e[2]}; }} = Ceil(1 / size) + 1;
Transfinite Surface{e[2]};
Recombine Surface{e[2]};
Physical Surface("all") = Surface{:};
