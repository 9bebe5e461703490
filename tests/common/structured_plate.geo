// Checker reference: a structured 2 x 1 plate. Meshed as is it gives triangles
// (each structured cell cut in two); with `-setnumber quads 1` it gives the
// quads made of exactly those triangle pairs, with the same node tags: a known
// perfect recombination for testing tests/check_mesh.py.
DefineConstant[ quads = {0, Choices {0, 1}, Name "quads"} ];
Point(1) = {0, 0, 0};
Point(2) = {2, 0, 0};
Point(3) = {2, 1, 0};
Point(4) = {0, 1, 0};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1, 3} = 9;
Transfinite Curve{2, 4} = 5;
Transfinite Surface{1};
If (quads)
  Recombine Surface{1};
EndIf
Physical Point("corner", 5) = {1};
Physical Curve("edges", 1) = {1, 2, 3, 4};
Physical Surface("plate", 2) = {1};
