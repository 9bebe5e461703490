// OpenCASCADE boolean: a box with a cylindrical hole through it and a spherical pocket.
SetFactory("OpenCASCADE");
DefineConstant[size = 0.3];
Box(1) = {0, 0, 0, 2, 1.5, 1};
Cylinder(2) = {1, 0.75, -0.5, 0, 0, 2, 0.4};
Sphere(3) = {0, 0, 1, 0.5};
BooleanDifference{ Volume{1}; Delete; }{ Volume{2, 3}; Delete; }
Mesh.MeshSizeMax = size;
Physical Surface("walls") = Surface{:};
