// OpenCASCADE cone (apex: a degenerate pole) and a truncated cone fused below it.
SetFactory("OpenCASCADE");
DefineConstant[size = 0.2];
Cone(1) = {0, 0, 0, 0, 0, 1, 0.6, 0};
Cone(2) = {2, 0, 0, 0, 0, 0.8, 0.7, 0.2};
Mesh.MeshSizeMax = size;
Physical Surface("skin") = Surface{:};
