// OCC chamfer of four edges of a box (planar strip faces meeting at sharp angles).
SetFactory("OpenCASCADE");
DefineConstant[size = 0.3];
Box(1) = {0, 0, 0, 2, 1.5, 1};
c() = Chamfer{1}{1, 3, 5, 7}{1, 1, 1, 1}{0.15};
Mesh.MeshSizeMax = size;
Physical Surface("skin") = Surface{:};
