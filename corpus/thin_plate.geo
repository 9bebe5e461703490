// A thin OCC plate with a hole: the side faces are far thinner than the mesh size.
SetFactory("OpenCASCADE");
DefineConstant[size = 0.3];
Box(1) = {0, 0, 0, 3, 2, 0.03};
Cylinder(2) = {1.5, 1, -1, 0, 0, 2, 0.4};
BooleanDifference{ Volume{1}; Delete; }{ Volume{2}; Delete; }
Mesh.MeshSizeMax = size;
Physical Surface("skin") = Surface{:};
