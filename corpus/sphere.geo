// OpenCASCADE sphere (one face, two poles, a seam) and a sphere cut by a plane.
SetFactory("OpenCASCADE");
DefineConstant[size = 0.25];
Sphere(1) = {0, 0, 0, 1};
Sphere(2) = {3, 0, 0, 0.8};
Box(3) = {2, -1, 0.3, 2, 2, 1};
BooleanDifference{ Volume{2}; Delete; }{ Volume{3}; Delete; }
Mesh.MeshSizeMax = size;
Physical Surface("skin") = Surface{:};
