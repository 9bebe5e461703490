// Planar domain with a Distance + Threshold size field around an internal curve and a point:
// strong grading (sizes from size/10 to size).
DefineConstant[size = 0.2];
Point(1) = {0, 0, 0, size}; Point(2) = {3, 0, 0, size};
Point(3) = {3, 2, 0, size}; Point(4) = {0, 2, 0, size};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1:4};
Plane Surface(1) = {1};
Point(5) = {0.5, 0.5, 0, size}; Point(6) = {2.2, 1.4, 0, size};
Line(5) = {5, 6};
Point(7) = {2.5, 0.4, 0, size};
Curve{5} In Surface{1};
Point{7} In Surface{1};
Field[1] = Distance; Field[1].CurvesList = {5}; Field[1].PointsList = {7}; Field[1].Sampling = 100;
Field[2] = Threshold; Field[2].InField = 1;
Field[2].SizeMin = size / 10; Field[2].SizeMax = size;
Field[2].DistMin = 0.05; Field[2].DistMax = 0.8;
Background Field = 2;
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeFromPoints = 0;
Physical Surface("all") = {1};
