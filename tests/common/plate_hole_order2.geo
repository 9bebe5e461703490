// Second-order test model: a 4 x 3 plate with a hole of radius 0.8 about (2, 1.5),
// two surfaces (left and right halves share a straight curve). `-setnumber size S` sets
// the element size; `-setnumber lines 0` puts only the surfaces in physical groups, so
// MSH 2.2 files carry no line elements. Meshed with `-order 2`.
DefineConstant[ size = {0.35, Name "size"} ];
DefineConstant[ lines = {1, Name "lines"} ];
SetFactory("OpenCASCADE");
Rectangle(1) = {0, 0, 0, 2, 3};
Rectangle(2) = {2, 0, 0, 2, 3};
Disk(3) = {2, 1.5, 0, 0.8};
BooleanDifference{ Surface{1, 2}; Delete; }{ Surface{3}; Delete; }
Coherence;
Physical Surface("plate", 1) = Surface{:};
If (lines)
  Physical Curve("edges", 2) = Curve{:};
EndIf
Mesh.MeshSizeMax = size;
Mesh.MeshSizeMin = size;
