// OCC fillet on the vertical edges of an L-shaped extruded plate plus a chamfer on the top
// edges of the notch (fillets meeting chamfers: many small curved faces).
SetFactory("OpenCASCADE");
DefineConstant[size = 0.25];
Box(1) = {0, 0, 0, 2, 2, 0.5};
Box(2) = {1, 1, -0.1, 1.1, 1.1, 0.7};
BooleanDifference(3) = { Volume{1}; Delete; }{ Volume{2}; Delete; };
v() = Curve In BoundingBox{-0.1, -0.1, -0.1, 2.1, 2.1, 0.6};
f() = Fillet{3}{v(0), v(2), v(4)}{0.1};
Mesh.MeshSizeMax = size;
Physical Surface("skin") = Surface{:};
