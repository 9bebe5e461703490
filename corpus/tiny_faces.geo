// Tiny model: a small box with a pyramid-like chamfered corner meshed coarse (faces of 1-3
// triangles, a triangular face, a pentagonal face).
SetFactory("OpenCASCADE");
DefineConstant[size = 2];
Box(1) = {0, 0, 0, 1, 1, 1};
c() = Chamfer{1}{1}{1}{0.3};
Mesh.MeshSizeMax = size;
Mesh.MeshSizeMin = size;
Physical Surface("all") = Surface{:};
