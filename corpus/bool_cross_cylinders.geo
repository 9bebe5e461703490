// OpenCASCADE boolean: union of three orthogonal cylinders (saddle-shaped intersection curves).
SetFactory("OpenCASCADE");
DefineConstant[size = 0.25];
Cylinder(1) = {-1, 0, 0, 2, 0, 0, 0.4};
Cylinder(2) = {0, -1, 0, 0, 2, 0, 0.4};
Cylinder(3) = {0, 0, -1, 0, 0, 2, 0.3};
BooleanUnion{ Volume{1}; Delete; }{ Volume{2, 3}; Delete; }
Mesh.MeshSizeMax = size;
Physical Surface("skin") = Surface{:};
