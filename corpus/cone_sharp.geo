// A very sharp OCC cone (apex half-angle ~3 degrees) and a flat wide cone, meshed with
// curvature-based sizes (bounded below).
SetFactory("OpenCASCADE");
DefineConstant[size = 0.3];
Cone(1) = {0, 0, 0, 0, 0, 2, 0.1, 0};
Cone(2) = {1, 0, 0, 0, 0, 0.1, 0.8, 0};
Mesh.MeshSizeMax = size;
Mesh.MeshSizeMin = size / 4;
Mesh.MeshSizeFromCurvature = 6;
Physical Surface("skin") = Surface{:};
