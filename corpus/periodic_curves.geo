// Planar square with a hole whose opposite sides are periodic curves (`Periodic Curve`),
// as in 2D homogenization cells.
SetFactory("OpenCASCADE");
DefineConstant[size = 0.1];
Rectangle(1) = {0, 0, 0, 1, 1};
Disk(2) = {0.5, 0.5, 0, 0.25, 0.18};
BooleanDifference(3) = { Surface{1}; Delete; }{ Surface{2}; Delete; };
Mesh.MeshSizeMax = size;
left() = Curve In BoundingBox{-0.01, -0.01, -0.01, 0.01, 1.01, 0.01};
right() = Curve In BoundingBox{0.99, -0.01, -0.01, 1.01, 1.01, 0.01};
bottom() = Curve In BoundingBox{-0.01, -0.01, -0.01, 1.01, 0.01, 0.01};
top() = Curve In BoundingBox{-0.01, 0.99, -0.01, 1.01, 1.01, 0.01};
Periodic Curve{right()} = {left()} Translate{1, 0, 0};
Periodic Curve{top()} = {bottom()} Translate{0, 1, 0};
Physical Surface("cell") = {3};
