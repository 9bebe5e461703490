// OpenCASCADE boolean: union of a box and a sphere centred on one of its faces.
SetFactory("OpenCASCADE");
DefineConstant[size = 0.3];
Box(1) = {0, 0, 0, 1, 1, 1};
Sphere(2) = {0.5, 0.5, 1, 0.45};
BooleanUnion{ Volume{1}; Delete; }{ Volume{2}; Delete; }
Mesh.MeshSizeMax = size;
Physical Surface("skin") = Surface{:};
