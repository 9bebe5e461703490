// OCC fillet of every edge of a box: cylindrical strips and spherical corner patches.
SetFactory("OpenCASCADE");
DefineConstant[size = 0.3];
Box(1) = {0, 0, 0, 2, 1.5, 1};
f() = Fillet{1}{1:12}{0.2};
Mesh.MeshSizeMax = size;
Physical Surface("skin") = Surface{:};
