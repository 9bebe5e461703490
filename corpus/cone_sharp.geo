// A very sharp cone (apex half-angle 2.9 degrees: height 2, base radius 0.1) and a flat
// wide cone (half-angle 83 degrees: height 0.1, base radius 0.8), each with its base disc,
// built with the built-in kernel: generator and base radius revolved in four quarter
// turns, with sizes shrinking to a quarter towards each apex. Gmsh meshes the OpenCASCADE
// cone of the same shape with repeated, folded and non-manifold triangles along its seam:
// that mesh is kept as a refused input (tests/data/quirks/v41_occ_sharp_cone_folded.msh).
DefineConstant[size = 0.3];
Function RevolvedCone
  // apex (0, 0, h) above the centre (cx, 0, 0) of a base of radius r
  p1 = newp; Point(p1) = {cx, 0, h, size / 4};
  p2 = newp; Point(p2) = {cx + r, 0, 0, size};
  p3 = newp; Point(p3) = {cx, 0, 0, size};
  g = newl; Line(g) = {p2, p1};
  b = newl; Line(b) = {p3, p2};
  For k In {1:4}
    a[] = Extrude {{0, 0, 1}, {cx, 0, 0}, Pi / 2} { Line{g}; };
    c[] = Extrude {{0, 0, 1}, {cx, 0, 0}, Pi / 2} { Line{b}; };
    g = a[0]; b = c[0];
  EndFor
Return
cx = 0; h = 2; r = 0.1; Call RevolvedCone;
cx = 1; h = 0.1; r = 0.8; Call RevolvedCone;
Coherence;
Mesh.MeshSizeMax = size;
Mesh.MeshSizeMin = size / 4;
Physical Surface("skin") = Surface{:};
