// Planar rectangle meshed anisotropically (BAMG) from a background mesh of metric tensors:
// stretched triangles along a sine-shaped band.
DefineConstant[size = 0.1];
Point(1) = {0, 0, 0, 1}; Point(2) = {2, 0, 0, 1};
Point(3) = {2, 1, 0, 1}; Point(4) = {0, 1, 0, 1};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1:4};
Plane Surface(1) = {1};
h1 = size; h2 = 5 * size;
m1 = 1 / (h1 * h1); m2 = 1 / (h2 * h2);
View "metric" {
  TT(0, 0, 0, 2, 0, 0, 2, 1, 0){m2, 0, 0, 0, m1, 0, 0, 0, 1, m1, 0, 0, 0, m2, 0, 0, 0, 1, m2, 0, 0, 0, m1, 0, 0, 0, 1};
  TT(0, 0, 0, 2, 1, 0, 0, 1, 0){m2, 0, 0, 0, m1, 0, 0, 0, 1, m2, 0, 0, 0, m1, 0, 0, 0, 1, m1, 0, 0, 0, m2, 0, 0, 0, 1};
};
Background Mesh View[0];
Mesh.Algorithm = 7;
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeFromPoints = 0;
Physical Surface("all") = {1};
