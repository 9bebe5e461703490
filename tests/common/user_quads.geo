// Quads the user made beside a triangle surface: a graded transfinite surface with
// Recombine (surface 1), a boundary layer extruded from its top curve with Recombine
// (graded layers), and an unstructured triangle surface on top of the layer. The tool
// recombines the triangles only; the two quad surfaces are written as read. At the
// default size the triangle surface is even (448 triangles): no parity repair.
DefineConstant[ size = {0.1, Name "size"} ];
Point(1) = {0, 0, 0, size};
Point(2) = {2, 0, 0, size};
Point(3) = {2.2, 1.1, 0, size};
Point(4) = {-0.3, 1, 0, size};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
// cells growing along x, clustered at the top and bottom
Transfinite Curve{1} = 21 Using Progression 1.12;
Transfinite Curve{3} = 21 Using Progression 1 / 1.12;
Transfinite Curve{2, 4} = 9 Using Bump 0.3;
Transfinite Surface{1};
Recombine Surface{1};
// the boundary layer: curve 3 extruded by 0.3, thin layers first
layer[] = Extrude {0, 0.3, 0} { Curve{3}; Layers{ {2, 2, 3}, {0.15, 0.4, 1} }; Recombine; };
// layer[0]: its top curve, from (2.2, 1.4) to (-0.3, 1.3); layer[1]: its surface
ends[] = Boundary{ Curve{layer[0]}; };
Point(10) = {2.2, 2.3, 0, size};
Point(11) = {-0.3, 2.3, 0, size};
Line(10) = {10, ends[0]};
Line(11) = {11, 10};
Line(12) = {ends[1], 11};
Curve Loop(2) = {layer[0], 12, 11, 10};
Plane Surface(2) = {2};
// parametric coordinates too (MSH 4.1; 0 for MSH 2.2, whose $ParametricNodes the tool
// does not read), to check they are kept
DefineConstant[ parametric = {1, Name "parametric"} ];
Mesh.SaveParametric = parametric;
