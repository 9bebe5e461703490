// A cylindrical boss fused on a plate, the junction edge filleted (toroidal fillet face).
SetFactory("OpenCASCADE");
DefineConstant[size = 0.25];
Box(1) = {-1.5, -1.5, 0, 3, 3, 0.4};
Cylinder(2) = {0, 0, 0.4, 0, 0, 1, 0.6};
BooleanUnion(3) = { Volume{1}; Delete; }{ Volume{2}; Delete; };
e() = Abs(Boundary{ Surface{:}; });
// the junction circle is the curve at z = 0.4 with radius 0.6
j() = Curve In BoundingBox{-0.61, -0.61, 0.39, 0.61, 0.61, 0.41};
f() = Fillet{3}{j()}{0.15};
Mesh.MeshSizeMax = size;
Physical Surface("skin") = Surface{:};
