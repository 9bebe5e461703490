// Thin wires: six cylinders of radius 0.03 to 0.06 (built-in kernel), each made of four
// quarter faces (four quarter arcs extruded along the axis) with two segments on each
// arc, so every quarter face is a strip two triangles around and neighbouring triangles
// meet at 45 degrees. Three wires are closed by flat end caps, three are open tubes.
// `size` is the segment length along the wires.
DefineConstant[size = 0.25];
n = 0;
For w In {0:5}
  r = 0.03 + 0.006 * w;
  len = 3 + 0.4 * w;
  x0 = 0.5 * w; y0 = 0.3 * (w % 2);
  c = newp; Point(c) = {x0, y0, 0};
  p1 = newp; Point(p1) = {x0 + r, y0, 0};
  p2 = newp; Point(p2) = {x0, y0 + r, 0};
  p3 = newp; Point(p3) = {x0 - r, y0, 0};
  p4 = newp; Point(p4) = {x0, y0 - r, 0};
  a1 = newc; Circle(a1) = {p1, c, p2};
  a2 = newc; Circle(a2) = {p2, c, p3};
  a3 = newc; Circle(a3) = {p3, c, p4};
  a4 = newc; Circle(a4) = {p4, c, p1};
  Transfinite Curve{a1, a2, a3, a4} = 3;
  tilt = 0.2 * (w - 2.5);
  out[] = Extrude{tilt, 0.1 * w, len}{ Curve{a1, a2, a3, a4}; };
  // out[] = {top curve, surface, side, side} per arc
  Transfinite Curve{out[0], out[4], out[8], out[12]} = 3;
  If (w % 2 == 0)
    cl = newcl; Curve Loop(cl) = {a1, a2, a3, a4};
    s = news; Plane Surface(s) = {cl};
    cl2 = newcl; Curve Loop(cl2) = {out[0], out[4], out[8], out[12]};
    s2 = news; Plane Surface(s2) = {cl2};
  EndIf
EndFor
Mesh.MeshSizeMax = size;
Mesh.MeshSizeFromCurvature = 0;
Physical Surface("wires") = Surface{:};
