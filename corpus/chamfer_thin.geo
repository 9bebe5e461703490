// OCC chamfer of eight edges with a tiny distance: sliver faces along all edges.
SetFactory("OpenCASCADE");
DefineConstant[size = 0.3];
Box(1) = {0, 0, 0, 1, 1, 1};
c() = Chamfer{1}{1:8}{1, 1, 1, 1, 2, 2, 2, 2}{0.01};
Mesh.MeshSizeMax = size;
Physical Surface("skin") = Surface{:};
