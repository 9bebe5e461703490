// Many small curved faces: a plate with 16 small cylindrical bosses and 9 small holes.
SetFactory("OpenCASCADE");
DefineConstant[size = 0.2];
Box(1) = {0, 0, 0, 4, 4, 0.3};
k = 10;
For i In {0:3}
  For j In {0:3}
    Cylinder(k) = {0.5 + i, 0.5 + j, 0.3, 0, 0, 0.15 + 0.05 * ((i + j) % 3), 0.12};
    k += 1;
  EndFor
EndFor
BooleanUnion(100) = { Volume{1}; Delete; }{ Volume{10:k-1}; Delete; };
k = 200;
For i In {1:3}
  For j In {1:3}
    Cylinder(k) = {i, j, -1, 0, 0, 2, 0.06};
    k += 1;
  EndFor
EndFor
BooleanDifference{ Volume{100}; Delete; }{ Volume{200:k-1}; Delete; }
Mesh.MeshSizeMax = size;
Physical Surface("skin") = Surface{:};
