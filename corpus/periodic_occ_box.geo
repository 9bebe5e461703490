// OpenCASCADE box with a cylindrical hole; all three pairs of opposite faces periodic
// (`Periodic Surface` on OCC faces), x pair cut by the hole.
SetFactory("OpenCASCADE");
DefineConstant[size = 0.2];
Box(1) = {0, 0, 0, 1, 1, 1};
Cylinder(2) = {-0.1, 0.5, 0.5, 1.2, 0, 0, 0.25};
BooleanDifference{ Volume{1}; Delete; }{ Volume{2}; Delete; }
Mesh.MeshSizeMax = size;
e = 1e-3;
xmin() = Surface In BoundingBox{-e, -e, -e, e, 1 + e, 1 + e};
xmax() = Surface In BoundingBox{1 - e, -e, -e, 1 + e, 1 + e, 1 + e};
ymin() = Surface In BoundingBox{-e, -e, -e, 1 + e, e, 1 + e};
ymax() = Surface In BoundingBox{-e, 1 - e, -e, 1 + e, 1 + e, 1 + e};
zmin() = Surface In BoundingBox{-e, -e, -e, 1 + e, 1 + e, e};
zmax() = Surface In BoundingBox{-e, -e, 1 - e, 1 + e, 1 + e, 1 + e};
Periodic Surface{xmax()} = {xmin()} Translate{1, 0, 0};
Periodic Surface{ymax()} = {ymin()} Translate{0, 1, 0};
Periodic Surface{zmax()} = {zmin()} Translate{0, 0, 1};
Physical Surface("skin") = Surface{:};
