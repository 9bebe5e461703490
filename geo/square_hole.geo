// The paper's planar test case (Remacle et al. 2012, section 8.1, after Borouchaki
// and Frey): the unit square with a circular hole of radius 0.15 centred at
// (0.75, 0.75); the size is small along the medial axis of the domain and grows
// linearly away from it.
//
//   gmsh -2 square_hole.geo -o square_hole.msh                 (~7e4 triangles)
//   gmsh -2 square_hole.geo -setnumber size 2.7 -o h.msh       (~1e4 triangles)
//   gmsh -2 square_hole.geo -setnumber size 0.27 -o h.msh      (~1e6 triangles)
//
// Medial-axis approximation. The boundary has five parts: the four sides
// (distances x, 1-x, y, 1-y) and the hole (distance |p - c| - 0.15). A point lies on
// the medial axis exactly when its two nearest boundary parts are equally far, so
// we use m = d2 - d1, with d1 <= d2 the two smallest of the five distances
// (d2 = the minimum over all pairs of the larger distance of the pair), as the
// "distance to the medial axis". It is 0 on the axis and grows linearly away
// from it (with slope 2 sin(theta / 2), theta the angle between the two parts'
// normals, instead of 1). The size field is
//     h = size * (0.003 + 0.03 m),
// i.e. the paper's h = 0.003 on the axis at size = 1. The paper does not give
// the growth rate; 0.03 is our choice. Every curve gets an odd number of nodes
// (see rectangle.geo: the 1D mesh is made with Mesh.RecombineAll = 1, then the
// caller's value is restored); set odd_curves = 0 for Gmsh's plain counts.

DefineConstant[
  size = {1, Min 0.01, Max 100, Name "Parameters/size"},
  odd_curves = {1, Choices {0, 1}, Name "Parameters/odd curves"}
];

SetFactory("OpenCASCADE");
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 0;
Mesh.MeshSizeExtendFromBoundary = 0;

Rectangle(1) = {0, 0, 0, 1, 1};
Disk(2) = {0.75, 0.75, 0, 0.15};
domain() = BooleanDifference{ Surface{1}; Delete; }{ Surface{2}; Delete; };

outer() = {};
hole() = {};
bnd() = Boundary{ Surface{domain()}; };
For i In {0 : #bnd() - 1}
  c = Abs(bnd(i));
  bb() = BoundingBox Curve{c};
  If (bb(0) > 0.5 && bb(1) > 0.5 && bb(3) < 0.95 && bb(4) < 0.95)
    hole() += c;
  Else
    outer() += c;
  EndIf
EndFor
Physical Curve("outer", 1) = {outer()};
Physical Curve("hole", 2) = {hole()};
Physical Surface("domain", 10) = {domain()};

// d1: nearest boundary part, d2: second nearest (see above).
Field[1] = MathEval;
Field[1].F = StrCat(Sprintf("%.17g * (0.003 + 0.03 * (", size),
  "min(min(min(min(min(min(min(min(min(max(x,(1-x)),max(x,y)),max(x,(1-y))),max(x,(sqrt((x-0.75)^2+(y-0.75)^2)-0.15))),max((1-x),y)),max((1-x),(1-y))),max((1-x),(sqrt((x-0.75)^2+(y-0.75)^2)-0.15))),max(y,(1-y))),max(y,(sqrt((x-0.75)^2+(y-0.75)^2)-0.15))),max((1-y),(sqrt((x-0.75)^2+(y-0.75)^2)-0.15)))",
  " - ",
  "min(min(min(min(x,(1-x)),y),(1-y)),(sqrt((x-0.75)^2+(y-0.75)^2)-0.15))",
  "))");
Background Field = 1;

If (odd_curves)
  caller_recombine_all = Mesh.RecombineAll;
  Mesh.RecombineAll = 1;
  Mesh 1;
  Mesh.RecombineAll = caller_recombine_all;
EndIf
