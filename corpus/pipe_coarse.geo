// A pipe (OpenCASCADE annulus of radii 0.3 and 0.2 swept along a straight leg, a
// 90-degree elbow and a second leg), meshed coarse: few segments around the
// circumference, so the end annuli are one or two triangles wide and the wall corners
// are close to 90 degrees.
SetFactory("OpenCASCADE");
DefineConstant[size = 0.25];
Disk(1) = {0, 0, 0, 0.3};
Disk(2) = {0, 0, 0, 0.2};
BooleanDifference{ Surface{1}; Delete; }{ Surface{2}; Delete; }
a[] = Extrude{0, 0, 1.5}{ Surface{1}; };
b[] = Extrude{{0, 1, 0}, {0.8, 0, 1.5}, Pi / 2}{ Surface{a[0]}; };
c[] = Extrude{1.2, 0, 0}{ Surface{b[0]}; };
Coherence;
Mesh.MeshSizeMax = size;
Physical Surface("pipe") = Surface{:};
