// OCC fillet with a radius far below the mesh size: thin strip faces of a few triangles.
SetFactory("OpenCASCADE");
DefineConstant[size = 0.3];
Box(1) = {0, 0, 0, 2, 1.5, 1};
f() = Fillet{1}{1:12}{0.02};
Mesh.MeshSizeMax = size;
Physical Surface("skin") = Surface{:};
