// Planar fragments: a rectangle cut by curves that come very close to each other,
// leaving sliver faces a small fraction of the mesh size wide.
SetFactory("OpenCASCADE");
DefineConstant[size = 0.2];
Rectangle(1) = {0, 0, 0, 3, 2};
Point(10) = {0, 1.0, 0}; Point(11) = {3, 1.0, 0};
Point(12) = {0, 1.02, 0}; Point(13) = {3, 1.03, 0};
Point(14) = {1.5, 0, 0}; Point(15) = {1.51, 2, 0};
Line(10) = {10, 11};
Line(11) = {12, 13};
Line(12) = {14, 15};
BooleanFragments{ Surface{1}; Delete; }{ Curve{10, 11, 12}; Delete; }
Mesh.MeshSizeMax = size;
Physical Surface("all") = Surface{:};
