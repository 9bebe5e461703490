// OpenCASCADE extrusion of a spline-and-line profile along z, with a hole.
SetFactory("OpenCASCADE");
DefineConstant[size = 0.2];
Point(1) = {0, 0, 0};
Point(2) = {2, 0, 0};
Point(3) = {2.3, 0.6, 0};
Point(4) = {1.5, 1.2, 0};
Point(5) = {0.6, 1.0, 0};
Point(6) = {0, 0.6, 0};
Line(1) = {1, 2};
Spline(2) = {2, 3, 4, 5};
Line(3) = {5, 6};
Line(4) = {6, 1};
Curve Loop(1) = {1:4};
Plane Surface(1) = {1};
Disk(2) = {1.2, 0.5, 0, 0.25};
BooleanDifference(3) = { Surface{1}; Delete; }{ Surface{2}; Delete; };
Extrude{0, 0, 0.8}{ Surface{3}; }
Mesh.MeshSizeMax = size;
Physical Surface("skin") = Surface{:};
