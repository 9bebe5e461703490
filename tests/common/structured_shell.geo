// Checker reference on a curved surface: half a cylinder (two surfaces) extruded
// in structured layers; triangles by default, the matching quads with
// `-setnumber quads 1` (same node tags). See structured_plate.geo.
DefineConstant[ quads = {0, Choices {0, 1}, Name "quads"} ];
Point(1) = {0, 0, 0};
Point(2) = {1, 0, 0};
Point(3) = {0, 1, 0};
Point(4) = {-1, 0, 0};
Circle(1) = {2, 1, 3};
Circle(2) = {3, 1, 4};
Transfinite Curve{1, 2} = 9;
If (quads)
  out[] = Extrude {0, 0, 1} { Curve{1, 2}; Layers{6}; Recombine; };
Else
  out[] = Extrude {0, 0, 1} { Curve{1, 2}; Layers{6}; };
EndIf
Physical Curve("rims", 3) = {1, 2};
Physical Surface("shell", 1) = {out[1], out[5]};
