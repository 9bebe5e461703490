// OpenCASCADE revolution of a closed profile by 360 degrees (faces with seam curves,
// degenerate poles where the profile touches the axis).
SetFactory("OpenCASCADE");
DefineConstant[size = 0.15];
Point(1) = {0, 0, 0};
Point(2) = {0.8, 0, 0};
Point(3) = {0.8, 0, 0.3};
Point(4) = {0.4, 0, 0.5};
Point(5) = {0.4, 0, 1.0};
Point(6) = {0, 0, 1.2};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 5};
Line(5) = {5, 6}; Line(6) = {6, 1};
Curve Loop(1) = {1:6};
Plane Surface(1) = {1};
Extrude{{0, 0, 1}, {0, 0, 0}, 2 * Pi}{ Surface{1}; }
Recursive Delete{ Surface{1}; }
Mesh.MeshSizeMax = size;
Physical Surface("skin") = Surface{:};
