// Planar comb with very sharp re-entrant and salient corners (5 to 350 degrees).
DefineConstant[size = 0.1];
p = 1;
Point(p) = {0, 0, 0, size}; p += 1;
For i In {0:5}
  Point(p) = {0.4 * i + 0.05, 1.0, 0, size}; p += 1;
  Point(p) = {0.4 * i + 0.1, 0.2, 0, size}; p += 1;
  Point(p) = {0.4 * i + 0.35, 1.3, 0, size}; p += 1;
EndFor
Point(p) = {2.4, 0, 0, size}; p += 1;
For i In {1:p-1}
  Line(i) = {i, i % (p - 1) + 1};
EndFor
Curve Loop(1) = {1:p-1};
Plane Surface(1) = {1};
Physical Surface("comb") = {1};
