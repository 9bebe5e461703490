// Planar square meshed from a background mesh: a post-processing view of scalar sizes
// defined inline (size small in one corner, large in the opposite one).
DefineConstant[size = 0.1];
Point(1) = {0, 0, 0, 1}; Point(2) = {1, 0, 0, 1};
Point(3) = {1, 1, 0, 1}; Point(4) = {0, 1, 0, 1};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1:4};
Plane Surface(1) = {1};
View "background" {
  ST(0, 0, 0, 1, 0, 0, 0, 1, 0){0.3 * size, 2 * size, 2 * size};
  ST(1, 0, 0, 1, 1, 0, 0, 1, 0){2 * size, 3 * size, 2 * size};
};
Background Mesh View[0];
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 0;
Physical Surface("all") = {1};
