// Planar gear: 40 teeth with short flanks and sharp corners, a keyed bore.
DefineConstant[size = 0.08];
n = 40; r1 = 1.0; r2 = 1.12; p = 1;
For i In {0:n-1}
  a = 2 * Pi * i / n; d = Pi / n;
  Point(p) = {r1 * Cos(a), r1 * Sin(a), 0, size}; p += 1;
  Point(p) = {r2 * Cos(a + 0.2 * d), r2 * Sin(a + 0.2 * d), 0, size}; p += 1;
  Point(p) = {r2 * Cos(a + 0.8 * d), r2 * Sin(a + 0.8 * d), 0, size}; p += 1;
  Point(p) = {r1 * Cos(a + d), r1 * Sin(a + d), 0, size}; p += 1;
EndFor
For i In {1:p-1}
  Line(i) = {i, i % (p - 1) + 1};
EndFor
Curve Loop(1) = {1:p-1};
q = 1000;
Point(q) = {0.3, -0.05, 0, size}; Point(q+1) = {0.3, 0.05, 0, size};
Point(q+2) = {0.35, 0.05, 0, size}; Point(q+3) = {0.35, -0.05, 0, size};
Point(q+4) = {0, 0, 0, size};
Point(q+5) = {-0.3, 0.0, 0, size};
Circle(q) = {q+1, q+4, q+5}; Circle(q+1) = {q+5, q+4, q};
Line(q+2) = {q, q+3}; Line(q+3) = {q+3, q+2}; Line(q+4) = {q+2, q+1};
Curve Loop(2) = {q, q+1, q+2, q+3, q+4};
Plane Surface(1) = {1, 2};
Physical Surface("gear") = {1};
