// Planar OpenCASCADE boolean: a plate minus 12 disks of different radii and a slot.
SetFactory("OpenCASCADE");
DefineConstant[size = 0.2];
Rectangle(1) = {0, 0, 0, 4, 2};
For i In {0:5}
  Disk(10 + i) = {0.4 + 0.6 * i, 0.5, 0, 0.1 + 0.03 * i};
  Disk(20 + i) = {0.4 + 0.6 * i, 1.4, 0, 0.22 - 0.02 * i};
EndFor
Rectangle(30) = {3.7, 0.2, 0, 0.1, 1.6, 0.04};
BooleanDifference{ Surface{1}; Delete; }{ Surface{10:15, 20:25, 30}; Delete; }
Mesh.MeshSizeMax = size;
Physical Surface("plate") = Surface{:};
