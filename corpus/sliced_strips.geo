// A sliced part: an OpenCASCADE cylinder with a box boss and a bore, fragmented by
// pairs of close parallel planes (gaps of 2 to 5 percent of the height), as sliced STEP
// parts come: the lateral faces between two close cuts are strips one triangle wide,
// the cut faces are internal faces shared by two slices.
SetFactory("OpenCASCADE");
DefineConstant[size = 0.2];
Cylinder(1) = {0, 0, 0, 0, 0, 2, 0.8};
Box(2) = {0.5, -0.3, 0.4, 0.7, 0.6, 1.0};
BooleanUnion{ Volume{1}; Delete; }{ Volume{2}; Delete; }
Cylinder(3) = {0, 0, -0.1, 0, 0, 2.2, 0.3};
BooleanDifference{ Volume{1}; Delete; }{ Volume{3}; Delete; }
z[] = {0.5, 0.54, 1.1, 1.14, 1.2, 1.5, 1.53};
For i In {0:#z[]-1}
  Rectangle(100 + i) = {-2, -2, z[i], 4, 4};
EndFor
BooleanFragments{ Volume{1}; Delete; }{ Surface{100:100 + #z[]-1}; Delete; }
// drop the parts of the cutting planes outside the part
outside() = Surface{:};
inside() = Surface In BoundingBox{-1.3, -1.3, -0.2, 1.3, 1.3, 2.2};
outside() -= inside();
Recursive Delete{ Surface{outside()}; }
Mesh.MeshSizeMax = size;
Physical Surface("slices") = Surface{:};
