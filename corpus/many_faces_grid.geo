// Many small faces: a plate fragmented by a 12 x 8 grid of small squares and disks
// (about 200 faces of a few triangles each at the coarse size).
SetFactory("OpenCASCADE");
DefineConstant[size = 0.15];
Rectangle(1) = {0, 0, 0, 3.6, 2.4};
k = 100;
For i In {0:11}
  For j In {0:7}
    If ((i + j) % 2 == 0)
      Rectangle(k) = {0.3 * i + 0.05, 0.3 * j + 0.05, 0, 0.2, 0.2};
    Else
      Disk(k) = {0.3 * i + 0.15, 0.3 * j + 0.15, 0, 0.1};
    EndIf
    k += 1;
  EndFor
EndFor
BooleanFragments{ Surface{1}; Delete; }{ Surface{100:k-1}; Delete; }
Mesh.MeshSizeMax = size;
Physical Surface("all") = Surface{:};
