// OCC solid: a box with a tiny step cut in one corner (edges of 0.005 next to edges of 2)
// and a small cylinder pin (short seam edges on a small face).
SetFactory("OpenCASCADE");
DefineConstant[size = 0.3];
Box(1) = {0, 0, 0, 2, 1, 1};
Box(2) = {1.995, 0.995, -0.1, 0.1, 0.1, 1.2};
Cylinder(3) = {1, 0.5, 1, 0, 0, 0.01, 0.05};
BooleanDifference(4) = { Volume{1}; Delete; }{ Volume{2}; Delete; };
BooleanUnion{ Volume{4}; Delete; }{ Volume{3}; Delete; }
Mesh.MeshSizeMax = size;
Physical Surface("skin") = Surface{:};
